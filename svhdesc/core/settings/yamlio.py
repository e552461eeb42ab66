"""YAML loading that rejects duplicate keys and remembers line numbers for error messages."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml

from svhdesc.errors import SvhdescError


class Node(dict):
    """A mapping that knows where it was written, and where each of its keys was."""

    where: str = ""
    lines: dict[Any, str]

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.lines = {}


class _Loader(yaml.SafeLoader):
    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> Node:  # type: ignore[override]
        lines: dict[Any, str] = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            try:
                duplicate = key in lines
            except TypeError:  # a list or mapping as a key
                raise SvhdescError(f"{self.name}:{key_node.start_mark.line + 1}: a key must be a plain value") from None
            if duplicate:
                raise SvhdescError(f"{self.name}:{key_node.start_mark.line + 1}: duplicate key '{key}'")
            lines[key] = f"{self.name}:{key_node.start_mark.line + 1}"
        mapping = Node(super().construct_mapping(node, deep=True))
        mapping.where = f"{self.name}:{node.start_mark.line + 1}"
        mapping.lines = lines
        return mapping


def _construct_map(loader: _Loader, node: yaml.MappingNode):  # type: ignore[no-untyped-def]
    # SafeLoader builds mappings through a generator that returns a plain dict; build ours.
    yield loader.construct_mapping(node, deep=True)


_Loader.add_constructor("tag:yaml.org,2002:map", _construct_map)

# YAML 1.1 reads ``1e-3`` (no dot) as text; every user means the number, as YAML 1.2 and JSON do.
_FLOAT = re.compile(r"^[-+]?(?:[0-9][0-9_]*)?(?:\.[0-9_]*)?[eE][-+]?[0-9]+$")
_Loader.yaml_implicit_resolvers = {k: list(v) for k, v in yaml.SafeLoader.yaml_implicit_resolvers.items()}
_Loader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT, list("-+0123456789."))


def _construct_int(loader: _Loader, node: yaml.ScalarNode) -> int:
    try:
        return yaml.SafeLoader.construct_yaml_int(loader, node)
    except ValueError:  # Python refuses to read integers of over 4300 digits
        raise SvhdescError(
            f"{loader.name}:{node.start_mark.line + 1}: integer {node.value[:20]}... is too long"
        ) from None


_Loader.add_constructor("tag:yaml.org,2002:int", _construct_int)


def load_yaml(path: Path) -> Any:
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise SvhdescError(f"{path}: cannot read ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise SvhdescError(f"{path}: not a UTF-8 text file") from None
    loader = _Loader(text)
    loader.name = str(path)
    try:
        return loader.get_single_data()
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark
        line = f":{mark.line + 1}" if mark else ""
        raise SvhdescError(f"{path}{line}: invalid YAML ({exc.problem})") from None
    except yaml.YAMLError as exc:
        raise SvhdescError(f"{path}: invalid YAML ({exc})") from None
    except RecursionError:
        raise SvhdescError(f"{path}{_deepest(text)}: invalid YAML (nested too deeply)") from None
    finally:
        loader.dispose()


def _deepest(text: str, limit: int = 100) -> str:
    """':LINE' where the nesting first goes ``limit`` levels deep: the event stream needs no recursion, so it can
    find the line the recursive constructor could not report."""
    depth = 0
    try:
        for event in yaml.parse(text, Loader=yaml.SafeLoader):
            if isinstance(event, (yaml.SequenceStartEvent, yaml.MappingStartEvent)):
                depth += 1
                if depth >= limit:
                    return f":{event.start_mark.line + 1}"
            elif isinstance(event, (yaml.SequenceEndEvent, yaml.MappingEndEvent)):
                depth -= 1
    except yaml.YAMLError:
        pass
    return ""


def where(node: Any, fallback: str, key: Any = None) -> str:
    """file:line of ``node`` (of its entry ``key`` if given and known), else ``fallback``."""
    if key is not None:
        line = getattr(node, "lines", {}).get(key)
        if line:
            return line
    return getattr(node, "where", "") or fallback
