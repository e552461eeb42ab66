"""ROS-free package lookup: ``$(find PKG)`` and ``package://PKG/...`` through an explicit map."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from svhdesc.errors import SvhdescError


def package_map(explicit: Mapping[str, Path], *, env: Mapping[str, str] | None = None) -> dict[str, Path]:
    """Explicit ``--package NAME=DIR`` entries win over packages found on ROS_PACKAGE_PATH."""
    env = os.environ if env is None else env
    found: dict[str, Path] = {}
    for root in filter(None, env.get("ROS_PACKAGE_PATH", "").split(os.pathsep)):
        root_path = Path(root)
        # A package is a directory holding package.xml, the root itself or one level down.
        for candidate in [root_path, *sorted(p for p in root_path.glob("*") if p.is_dir())]:
            if (candidate / "package.xml").is_file():
                found.setdefault(candidate.name, candidate.resolve())
    found.update({name: Path(path).resolve() for name, path in explicit.items()})
    return found


def parse_package_option(value: str) -> tuple[str, Path]:
    name, sep, directory = value.partition("=")
    if not sep or not name or not directory:
        raise SvhdescError(f"--package {value!r}: expected NAME=DIR")
    path = Path(directory)
    if not path.is_dir():
        raise SvhdescError(f"--package {name}: directory {directory} does not exist")
    return name, path.resolve()


def find_package(name: str, packages: Mapping[str, Path], where: str) -> Path:
    if not name:
        raise SvhdescError(f"{where}: a package reference names no package")
    try:
        return packages[name]
    except KeyError:
        known = ", ".join(sorted(packages)) or "none"
        raise SvhdescError(f"{where}: unknown package '{name}' (known: {known}; add --package {name}=DIR)") from None


def resolve_uri(uri: str, packages: Mapping[str, Path], where: str) -> Path:
    """Turn a mesh URI (package://, file://, absolute or relative path) into a file path."""
    if uri.startswith("package://"):
        # package:///NAME/rest (an empty authority, as Talos' URDF writes it) reads as package://NAME/rest: pinocchio,
        # for which example-robot-data writes them, joins the path after "package://" to a package folder.
        name, _, rest = uri[len("package://") :].lstrip("/").partition("/")
        if not name or not rest:
            raise SvhdescError(f"{where}: {uri}: a package URI needs package://NAME/PATH")
        root = find_package(name, packages, where)
        inside = os.path.normpath(rest)
        if inside == ".." or inside.startswith(("../", "/")):
            raise SvhdescError(f"{where}: {uri} leaves package '{name}' ({root}): a package URI names a file inside it")
        return root / rest
    if uri.startswith("file://"):
        return Path(uri[len("file://") :])
    return Path(uri)


def package_name_of(directory: Path) -> str | None:
    """The <name> in ``directory``/package.xml, or None when it is no ROS package."""
    from lxml import etree

    try:
        name = etree.parse(os.fsencode(directory / "package.xml")).findtext("name")
    except (OSError, etree.XMLSyntaxError):
        return None
    return name.strip() if name else None


def local_mesh_path(uri: str, base: Path, env: Mapping[str, str] | None = None) -> Path | None:
    """A mesh URI of a built model as a local file: package://NAME/... of the package at ``base`` (the model's
    own folder) or on ROS_PACKAGE_PATH, file:// URIs, absolute and relative paths. None if nothing resolves it.

    model://NAME/... (what sdformat makes of package:// URIs; Gazebo resolves it on its resource path, which holds
    the folder of packages) resolves the same way."""
    scheme = next((s for s in ("package://", "model://") if uri.startswith(s)), None)
    if scheme is not None:
        name, _, rest = uri[len(scheme) :].partition("/")
        if package_name_of(base) == name:
            return base / rest
        root = package_map({}, env=env).get(name)
        return root / rest if root is not None else None
    if uri.startswith("file://"):
        return Path(uri[len("file://") :])
    if "://" in uri:
        return None
    path = Path(uri)
    return path if path.is_absolute() else base / path


def find_beside(name: str, source: Path) -> Path | None:
    """Where ROS would find package ``name`` for a source file: the folder above the source that is that
    package (its package.xml names it) or that holds a folder of that name.

    Of two folders above the source that are both package ``name`` (a ROS 2 package nested in the ROS 1 package whose
    folder it installs as its share, as svhdesc's generated/<variant>/ros2 is), the outer one wins: a workspace crawl
    (rospack, colcon) stops descending at the first package.xml it meets, so the nested one is never seen."""
    folders = source.resolve().parents
    named = [folder for folder in folders if package_name_of(folder) == name]
    if named:
        return named[-1]
    return next((folder / name for folder in folders if (folder / name).is_dir()), None)
