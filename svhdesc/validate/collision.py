"""Check 7: no two robot bodies penetrate at any keyframe (bare model: no floor to ignore), any robot.

Pairs the model excludes (``<contact><exclude>``, parent and child) never make a contact; every other pair
deeper than 0 (MuJoCo's contact distance < 0) is named with its depth.

Keyframes that close a configured grasp are left out: they command the fingers past where the object
stops them, so without it they overlap by design (the grasps check simulates them).
"""

from __future__ import annotations

from svhdesc.validate.options import Options
from svhdesc.validate.pair import ModelPair
from svhdesc.validate.report import Check, fmt, not_run, skipped, verdict


def check_self_collision(pair: ModelPair, options: Options) -> list[Check]:
    import mujoco

    bound = "0 penetrating pairs of robot bodies (excluded pairs aside)"
    if pair.model is None:
        return [not_run("self_collision", "the MJCF does not compile", bound)]
    model = pair.model
    if model.nkey == 0:
        return [skipped("self_collision", "no keyframes", bound)]
    data = mujoco.MjData(model)
    found: dict[str, list[dict[str, object]]] = {}
    deepest = 0.0
    grasps = set(pair.configuration.settings.grasps) if pair.configuration is not None else set()
    for key in range(model.nkey):
        if model.key(key).name in grasps:
            continue
        mujoco.mj_resetDataKeyframe(model, data, key)
        mujoco.mj_forward(model, data)
        pairs: dict[tuple[str, str], float] = {}
        for contact in data.contact[: data.ncon]:
            body1, body2 = model.geom_bodyid[contact.geom1], model.geom_bodyid[contact.geom2]
            if body1 == 0 or body2 == 0:
                continue  # something fixed to the world (a floor in a scene), not the robot
            if contact.dist >= 0:
                continue  # within a margin, not penetrating
            names = (model.body(body1).name, model.body(body2).name)
            pairs[names] = min(pairs.get(names, 0.0), float(contact.dist))
        if pairs:
            found[model.key(key).name] = [{"bodies": list(k), "penetration_m": -v} for k, v in pairs.items()]
            deepest = max(deepest, *(-v for v in pairs.values()))
    keys = [model.key(k).name for k in range(model.nkey) if model.key(k).name not in grasps]
    count = sum(len(v) for v in found.values())
    detail = "; ".join(
        f"{key}: " + ", ".join(f"{p['bodies'][0]}/{p['bodies'][1]} {p['penetration_m'] * 1e3:.3g} mm" for p in pairs)
        for key, pairs in found.items()
    ) or f"keyframes {', '.join(keys)}" + (f" (grasps left out: {', '.join(sorted(grasps))})" if grasps else "")
    return [
        Check(
            "self_collision",
            verdict(not found),
            f"{count} pairs, deepest {fmt(deepest)} m",
            bound,
            detail,
            {"keyframes": keys, "contacts": found},
        )
    ]
