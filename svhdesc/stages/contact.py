"""Grasp contact model and friction: condim and coefficients per link."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from ..config import CONTACT_MODELS
from ..ir import Contact, Robot


def fingertip_links(robot: Robot, hand: dict[str, Any]) -> list[str]:
    names = {link.name for link in robot.links}
    return [f"{hand['prefix']}_{tip}" for tip in hand.get("fingertips", []) if f"{hand['prefix']}_{tip}" in names]


def add_contact(robot: Robot, contact: dict[str, Any], hand: dict[str, Any]) -> Robot:
    """Fingertips get the selected grasp contact model; every other link hard-finger friction."""
    model = contact.get("model", "soft_finger")
    condim = CONTACT_MODELS[model]
    tips = set(fingertip_links(robot, hand))
    sliding = 0.0 if model == "point" else float(contact.get("sliding", 1.0))
    tip = Contact(
        mu=sliding,
        torsional=float(contact.get("torsional", 0.0)) if condim >= 4 else 0.0,
        rolling=float(contact.get("rolling", 0.0)) if condim >= 6 else 0.0,
        condim=condim,
    )
    other = Contact(mu=float(contact.get("default_sliding", 0.8)), condim=3)
    links = [
        replace(link, contact=tip if link.name in tips else other) if link.collisions else link for link in robot.links
    ]
    return replace(robot, links=tuple(links))
