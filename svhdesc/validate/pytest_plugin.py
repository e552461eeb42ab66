"""pytest plugin (entry point ``pytest11``): plain ``pytest`` validates the models a repository's [tool.svhdesc] table
lists, one item per model and check (``urdf/arm.urdf.xacro::joint_limits[side=left]``: a xacro's argument choices as
pytest writes parameters).

A failure's message is the check's findings at their file:line; a skipped check says why. Each model is validated
once per session (per xdist worker), when its first check runs, and its checks share that report; with
``--dist loadgroup`` a model's checks stay on one worker. The models join the items pytest collects when it runs
without file arguments (its testpaths or the working folder), or with ``--svhdesc``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("svhdesc", "robot models validated by svhdesc")
    group.addoption(
        "--svhdesc",
        action="store_true",
        help="validate the models [tool.svhdesc] lists even when pytest is given paths",
    )


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "svhdesc: a check of a robot model that [tool.svhdesc] lists")


class CheckFailed(Exception):
    pass


class ModelFile(pytest.File):
    """One model (a file, with one combination of its xacro arguments); its items are its checks."""

    run: Any  # svhdesc.validate.models.ModelRun
    _report: Any = None

    def collect(self):  # type: ignore[no-untyped-def]
        grouped = self.config.pluginmanager.hasplugin("xdist")
        parameters = self.run.label[len(str(self.run.path)) :]  # "[side=left]", or ""
        for check in self.run.checks():
            item = CheckItem.from_parent(self, name=check + parameters, check=check)
            item.add_marker(pytest.mark.svhdesc)
            if grouped:
                item.add_marker(pytest.mark.xdist_group(name=self.nodeid + parameters))
            yield item

    def report(self):  # type: ignore[no-untyped-def]
        if self._report is None:
            self._report = self.run.run()
        return self._report


class CheckItem(pytest.Item):
    def __init__(self, *, check: str, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.check = check

    def runtest(self) -> None:
        report = self.parent.report()  # type: ignore[attr-defined]
        result = next((c for c in report.checks if c.name == self.check), None)
        if result is None:
            pytest.skip("not run on this model")
        if result.status == "skipped":
            pytest.skip(result.reason)
        if result.status == "fail":
            lines = [
                f"{f.where()}: {f.message}" + (f" (would pass: {f.remedy})" if f.remedy else "")
                for f in result.findings
            ]
            raise CheckFailed("\n".join(lines))

    def repr_failure(self, excinfo, style=None):  # type: ignore[no-untyped-def]
        if isinstance(excinfo.value, CheckFailed):
            return str(excinfo.value)
        return super().repr_failure(excinfo, style)

    def reportinfo(self) -> tuple[Path, int | None, str]:
        return self.path, None, f"{self.parent.name}::{self.name}"


def _wanted(config: pytest.Config) -> bool:
    return bool(config.getoption("svhdesc")) or config.args_source != pytest.Config.ArgsSource.ARGS


@pytest.hookimpl(tryfirst=True)  # before -k and -m deselect
def pytest_collection_modifyitems(session: pytest.Session, config: pytest.Config, items: list[pytest.Item]) -> None:
    if not _wanted(config):
        return
    from svhdesc.errors import SvhdescError
    from svhdesc.validate.settings import find_pyproject

    pyproject = find_pyproject(config.rootpath)
    if pyproject is None or "[tool.svhdesc" not in pyproject.read_text(encoding="utf-8", errors="replace"):
        return
    try:
        items.extend(_model_items(session, pyproject))
    except SvhdescError as exc:
        raise pytest.UsageError(f"svhdesc: {exc}") from None


def _model_items(session: pytest.Session, pyproject: Path) -> list[pytest.Item]:
    from svhdesc.validate.files import known_checks
    from svhdesc.validate.models import CommandLine, model_runs
    from svhdesc.validate.settings import load_settings

    settings = load_settings(pyproject.parent)
    items: list[pytest.Item] = []
    for run in model_runs(settings.model_files(), settings, CommandLine(), known_checks()):
        model = ModelFile.from_parent(session, path=Path(run.path).resolve())
        model.run = run
        items.extend(model.collect())
    return items
