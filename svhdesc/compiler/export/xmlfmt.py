"""Number formatting and XML serialisation shared by the exporters."""

from __future__ import annotations

from collections.abc import Iterable

from lxml import etree


def num(value: float) -> str:
    """Shortest text that round-trips the float exactly (so URDF and MJCF agree bit for bit)."""
    value = float(value)
    if value == 0.0:
        return "0"
    text = repr(value)
    return text[:-2] if text.endswith(".0") else text


def nums(values: Iterable[float]) -> str:
    return " ".join(num(v) for v in values)


def sub(parent: etree._Element, tag: str, **attrs: str) -> etree._Element:
    return etree.SubElement(parent, tag, {k.rstrip("_"): v for k, v in attrs.items()})


def serialise(root: etree._Element) -> bytes:
    etree.indent(root, space="  ")
    return etree.tostring(root, xml_declaration=True, encoding="utf-8", pretty_print=True)
