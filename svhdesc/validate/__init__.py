"""``svhdesc validate`` and ``svhdesc render``: check a built URDF + MJCF pair against each other,
against real parsers and in simulation; draw a variant offscreen."""

from svhdesc.validate.options import Options
from svhdesc.validate.report import FAIL, NOT_RUN, PASS, SKIPPED, Check, VariantReport
from svhdesc.validate.runner import CHECK_NAMES, GROUPS, built_variants, select_checks, validate_files, validate_pair

__all__ = [
    "CHECK_NAMES",
    "FAIL",
    "GROUPS",
    "NOT_RUN",
    "PASS",
    "SKIPPED",
    "Check",
    "Options",
    "VariantReport",
    "built_variants",
    "select_checks",
    "validate_files",
    "validate_pair",
]
