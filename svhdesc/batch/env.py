"""The batched environment: one mujoco_warp Model, ``nworld`` worlds of Data, numpy in and out."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from svhdesc.batch.device import warp_device
from svhdesc.errors import SvhdescError
from svhdesc.extras import require

# Overflow bits that mean Warp dropped something (contacts, constraint rows, candidates). ITERATIONS and
# LS_ITERATIONS only say the solver stopped at its iteration limit, as MuJoCo C does without a word.
DROPS = (
    "NEFC",
    "NJMAX_NNZ",
    "BROADPHASE",
    "NARROWPHASE",
    "CCD",
    "HFIELD",
    "CONTACT_MATCH",
    "NVMAX",
    "EPA_HORIZON",
    "TACTILE",
)
WHAT = {"NEFC": "constraint rows above njmax", "BROADPHASE": "broadphase pairs above nconmax"}


class BatchOverflow(SvhdescError):
    """A world needed more contacts or constraint rows than the model's capacities hold."""


def fingertip_bodies(model: Any) -> list[int]:
    """Leaf bodies that carry collision geometry: the five distal phalanges, in body order."""
    parents = set(int(p) for p in model.body_parentid[1:])
    filters = model.geom_contype | model.geom_conaffinity
    colliding = {int(model.geom_bodyid[g]) for g in range(model.ngeom) if filters[g]}
    return [b for b in range(1, model.nbody) if b not in parents and b in colliding]


def touch_addresses(model: Any) -> list[int]:
    import mujoco

    touch = int(mujoco.mjtSensor.mjSENS_TOUCH)
    return [int(model.sensor_adr[s]) for s in range(model.nsensor) if int(model.sensor_type[s]) == touch]


class BatchEnv:
    """``nworld`` copies of one MuJoCo model stepped together on a Warp device."""

    def __init__(
        self,
        model: Any,
        nworld: int,
        device: str = "cpu",
        nconmax: int | None = None,
        njmax: int | None = None,
        batched: Sequence[str] = (),
    ) -> None:
        """``batched``: model fields (e.g. "geom_friction") that get one value per world, for randomisation."""
        self.wp = require("warp", "svhdesc.batch", "batch")
        self.mjw = require("mujoco_warp", "svhdesc.batch", "batch")
        if nworld < 1:
            raise ValueError(f"nworld must be at least 1, not {nworld}")
        self.mjm = model
        self.nworld = nworld
        self.nconmax = int(nconmax if nconmax is not None else model.nconmax)
        self.njmax = int(njmax if njmax is not None else model.njmax)
        if self.nconmax < 0 or self.njmax < 0:
            raise SvhdescError("the model states no <size nconmax njmax>: pass nconmax= and njmax= to make()")
        self.device = warp_device(self.wp, device)
        self.fingertips = fingertip_bodies(model)
        self.fingertip_names = [model.body(b).name for b in self.fingertips]
        self._touch = touch_addresses(model)
        self.touch_names = [model.sensor(s).name for s in range(model.nsensor) if model.sensor_adr[s] in self._touch]
        self._drops = 0
        for name in DROPS:
            self._drops |= int(getattr(self.mjw.OverflowType, name, 0))
        with self.wp.ScopedDevice(self.device):
            self.model = self.mjw.put_model(model, batch_sizes=dict.fromkeys(batched, nworld))
            self.data = self.mjw.make_data(model, nworld=nworld, nconmax=self.nconmax, njmax=self.njmax)
        self._graphs: dict[int, Any] = {}

    @property
    def nu(self) -> int:
        return int(self.mjm.nu)

    def keyframe(self, name: str) -> int:
        import mujoco

        key = mujoco.mj_name2id(self.mjm, mujoco.mjtObj.mjOBJ_KEY, name)
        if key < 0:
            known = ", ".join(self.mjm.key(k).name for k in range(self.mjm.nkey))
            raise KeyError(f"no keyframe {name!r} (known: {known})")
        return key

    def reset(self, keyframe: str | Sequence[str] = "home", worlds: Sequence[int] | np.ndarray | None = None) -> None:
        """Reset worlds (all, or the indices in ``worlds``) to a keyframe, or one keyframe name per world."""
        if isinstance(keyframe, str):
            keys = np.full(self.nworld, self.keyframe(keyframe), dtype=np.int32)
        else:
            if len(keyframe) != self.nworld:
                raise ValueError(f"one keyframe per world: {self.nworld} names, got {len(keyframe)}")
            keys = np.array([self.keyframe(k) for k in keyframe], dtype=np.int32)
        if worlds is not None:
            chosen = np.zeros(self.nworld, dtype=bool)
            chosen[np.asarray(worlds, dtype=int)] = True
            keys[~chosen] = -1  # mujoco_warp leaves worlds with a negative key as they are
        with self.wp.ScopedDevice(self.device):
            self.mjw.reset_data_keyframe(self.model, self.data, self.wp.array(keys, dtype=int))

    def set_ctrl(self, ctrl: np.ndarray) -> None:
        ctrl = np.asarray(ctrl, dtype=np.float32)
        if ctrl.shape != (self.nworld, self.nu):
            raise ValueError(f"ctrl must have shape ({self.nworld}, {self.nu}), not {ctrl.shape}")
        self.data.ctrl.assign(ctrl)

    def step(self, ctrl: np.ndarray | None = None, nstep: int = 1) -> None:
        """Set the servo targets (if given), take ``nstep`` physics steps, then raise on any overflow."""
        if ctrl is not None:
            self.set_ctrl(ctrl)
        self.advance(nstep)
        self.check_overflow()

    def advance(self, nstep: int = 1) -> None:
        """``nstep`` physics steps of every world, nothing copied and no overflow check (``check_overflow``: Warp's
        flags stay set, so one check after many steps finds any overflow among them)."""
        with self.wp.ScopedDevice(self.device):
            if self.device.is_cuda:
                self._launch_graph(nstep)
            else:
                for _ in range(nstep):
                    self.mjw.step(self.model, self.data)

    def _launch_graph(self, nstep: int) -> None:
        # On a GPU the kernel launches of one step cost more than the physics: replay a captured graph.
        # Kernels load lazily and cannot load during a capture, so the first call steps plainly.
        if not self._graphs:
            self._graphs[0] = None
            for _ in range(nstep):
                self.mjw.step(self.model, self.data)
            return
        if nstep not in self._graphs:
            with self.wp.ScopedCapture() as capture:
                for _ in range(nstep):
                    self.mjw.step(self.model, self.data)
            self._graphs[nstep] = capture.graph  # recorded, not run: launched below
        self.wp.capture_launch(self._graphs[nstep])

    def check_overflow(self) -> None:
        flags = self.data.overflow.numpy() & self._drops
        bad = np.flatnonzero(flags)
        if len(bad) == 0:
            return
        bits = int(np.bitwise_or.reduce(flags[bad]))
        kinds = [WHAT.get(name, name.lower()) for name in DROPS if bits & int(getattr(self.mjw.OverflowType, name, 0))]
        raise BatchOverflow(
            f"MuJoCo Warp overflow in {len(bad)} of {self.nworld} worlds (first: {bad[0]}): {', '.join(kinds)}; "
            f"capacities nconmax={self.nconmax} njmax={self.njmax} per world: raise them (make(..., nconmax=, "
            "njmax=) or <size> in scene_batch.xml)"
        )

    def observations(self) -> dict[str, np.ndarray]:
        """qpos [nworld, nq], qvel [nworld, nv], fingertips [nworld, 5, 3] (world frame), touch [nworld, ntouch]."""
        sensordata = self.data.sensordata.numpy()
        return {
            "qpos": self.data.qpos.numpy().astype(float),
            "qvel": self.data.qvel.numpy().astype(float),
            "fingertips": self.data.xpos.numpy()[:, self.fingertips].astype(float),
            "touch": sensordata[:, self._touch].astype(float),
        }


def make(
    variant: str,
    nworld: int = 1,
    device: str = "cpu",
    nconmax: int | None = None,
    njmax: int | None = None,
    scene: Path | None = None,
) -> BatchEnv:
    """``nworld`` worlds of the variant's batch scene (or of ``scene``) on ``device`` ("cpu", "cuda", "cuda:1")."""
    from svhdesc.model import get

    mujoco = require("mujoco", "svhdesc.batch", "batch")
    path = scene if scene is not None else get(variant).batch_scene_path
    if not Path(path).is_file():
        raise SvhdescError(f"{path}: no batch scene (rebuild: svhdesc build {variant})")
    return BatchEnv(mujoco.MjModel.from_xml_path(str(path)), nworld, device, nconmax, njmax)
