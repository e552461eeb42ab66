"""Expand a Xacro file with the ``xacro`` package and no ROS installation."""

from __future__ import annotations

import re
import xml.dom.minidom
from collections.abc import Mapping
from pathlib import Path
from xml.parsers.expat import ExpatError

from lxml import etree

from .errors import SvhdescError
from .packages import find_package


def expand_xacro(
    path: Path, args: Mapping[str, str], packages: Mapping[str, Path]
) -> tuple[etree._Element, list[Path]]:
    """The expanded URDF as an lxml tree, and every file xacro read (includes, YAML).

    Errors name file:line where it can be found.
    """
    import xacro.substitution_args as subst

    import xacro

    if not path.is_file():
        raise SvhdescError(f"{path}: Xacro file not found")

    failures: list[SvhdescError] = []

    def find(pkg: str) -> str:
        where = xacro.filestack[-1] if xacro.filestack else str(path)
        try:
            return str(find_package(pkg, packages, _locate(Path(where), f"$(find {pkg})")))
        except SvhdescError as exc:
            failures.append(exc)  # xacro wraps exceptions; keep ours to re-raise unchanged
            raise

    # xacro resolves $(find) through ament; route it through our map instead.
    saved = subst._eval_find, subst._eval_dict["find"]
    subst._eval_find = find
    subst._eval_dict["find"] = find
    xacro.all_includes = []
    try:
        doc: xml.dom.minidom.Document = xacro.process_file(str(path), mappings={k: str(v) for k, v in args.items()})
    except SvhdescError:
        raise
    except ExpatError as exc:
        where = xacro.filestack[-1] if xacro.filestack else path
        raise SvhdescError(f"{where}:{exc.lineno}: malformed XML ({exc.args[0].split(':')[0]})") from None
    except Exception as exc:  # xacro raises XacroException, NameError, KeyError, ...
        if failures:
            raise failures[0] from None
        where = Path(xacro.filestack[-1]) if xacro.filestack else path
        message = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        quoted = re.search(r"'([^']+)'", message)
        token = quoted.group(1) if quoted else None
        # A macro's body fails where it is called: look for the culprit in the included files too.
        files = [where, *(Path(f) for f in xacro.all_includes if Path(f) != where)]
        located = next((found for f in files if (found := _locate(f, token)) != str(f)), str(where))
        raise SvhdescError(f"{located}: xacro: {message}") from None
    finally:
        subst._eval_find, subst._eval_dict["find"] = saved
    inputs = [path.resolve(), *(Path(f).resolve() for f in xacro.all_includes)]
    return etree.fromstring(doc.toxml().encode()), list(dict.fromkeys(inputs))


def _locate(file: Path, token: str | None) -> str:
    """``file:line`` of the first line mentioning ``token``; xacro itself reports no lines."""
    if token:
        try:
            for number, line in enumerate(file.read_text().splitlines(), start=1):
                if token in line:
                    return f"{file}:{number}"
        except OSError:
            pass
    return str(file)
