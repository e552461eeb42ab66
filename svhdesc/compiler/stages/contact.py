"""Grasp contact model and friction: condim and coefficients per link."""

from __future__ import annotations

from dataclasses import replace

from svhdesc.compiler.assets import Assets
from svhdesc.core.settings import schema as settings
from svhdesc.core.settings.schema import CONTACT_MODELS, Hand
from svhdesc.ir import Contact, Robot


def fingertip_links(robot: Robot, hand: Hand) -> list[str]:
    names = {link.name for link in robot.links}
    return [hand.link(tip) for tip in hand.fingertips if hand.link(tip) in names]


def add_contact(robot: Robot, assets: Assets, section: tuple[settings.Contact, Hand]) -> Robot:
    """Fingertips get the selected grasp contact model; every other link hard-finger friction."""
    contact, hand = section
    condim = CONTACT_MODELS[contact.model]
    tips = set(fingertip_links(robot, hand))
    tip = Contact(
        mu=0.0 if contact.model == "point" else contact.sliding,
        torsional=contact.torsional if condim >= 4 else 0.0,
        rolling=contact.rolling if condim >= 6 else 0.0,
        condim=condim,
    )
    other = Contact(mu=contact.default_sliding, condim=3)
    links = [
        replace(link, contact=tip if link.name in tips else other) if link.collisions else link for link in robot.links
    ]
    return replace(robot, links=tuple(links))
