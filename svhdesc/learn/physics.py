"""The state a task reads and writes, as torch tensors over every world, from either engine.

``WarpPhysics`` keeps everything on the Warp device: each tensor is ``wp.to_torch`` of MuJoCo Warp's own array, so a
task's observations, rewards and resets never leave the device (no numpy on the hot path). ``CPhysics`` steps the same
scene in MuJoCo C, one ``MjData`` per world, and exposes stacked copies under the same names: it is how a policy
trained in the batch runs on the main model (noslip, multi-contact) through the same task code.

Both expose per-world model parameters (``model[field]``, [nworld, ...]) for domain randomisation: writing them
changes that world's physics from its next step.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any, Protocol

import numpy as np

from svhdesc.batch.env import BatchEnv
from svhdesc.errors import SvhdescError
from svhdesc.extras import require

# Data fields a task reads (qpos, qvel, ctrl written by the action, xpos/xquat after kinematics, actuator_force).
STATE_FIELDS = ("qpos", "qvel", "ctrl", "xpos", "xquat", "actuator_force", "time")
WRITTEN = ("qpos", "qvel")  # state a task's reset writes (ctrl is written every step)
# Model fields a task may randomise per world.
MODEL_FIELDS = (
    "geom_friction",
    "geom_size",
    "geom_rbound",
    "geom_aabb",
    "body_mass",
    "body_inertia",
    "body_invweight0",
    "actuator_gainprm",
    "actuator_biasprm",
    "dof_damping",
    "body_gravcomp",
)


class Physics(Protocol):
    nworld: int
    mjm: Any  # the compiled mujoco.MjModel (shared, unrandomised)
    device: Any  # torch.device
    state: dict[str, Any]  # STATE_FIELDS -> tensors [nworld, ...]
    model: dict[str, Any]  # MODEL_FIELDS -> tensors [nworld, ...]

    def step(self, nstep: int) -> None: ...

    def kinematics(self) -> None: ...

    def check_overflow(self) -> None: ...

    def commit_model(self) -> None: ...

    def diverged(self) -> Any: ...

    def clear(self, mask: Any) -> None: ...


MAX_SPEED = 1000.0  # rad/s or m/s: a world faster than this anywhere has blown up, whatever its numbers say


class WarpPhysics:
    """``nworld`` worlds on MuJoCo Warp; ``state`` and ``model`` are zero-copy torch views of Warp's arrays."""

    def __init__(self, mjm: Any, nworld: int, device: str, nconmax: int, njmax: int) -> None:
        torch = require("torch", "svhdesc.learn", "rl")
        self.batch = BatchEnv(mjm, nworld, device, nconmax, njmax, batched=MODEL_FIELDS)
        self.wp, self.mjw = self.batch.wp, self.batch.mjw
        self.nworld, self.mjm = nworld, mjm
        self.device = torch.device(str(self.batch.device))
        self.state = {name: self.wp.to_torch(getattr(self.batch.data, name)) for name in STATE_FIELDS}
        self.model = {name: self.wp.to_torch(getattr(self.batch.model, name)) for name in MODEL_FIELDS}
        if self.batch.device.is_cuda:
            # One stream for both libraries, so a tensor torch writes is ready for Warp's next kernel and back, with
            # no synchronisation; a stream of its own, not CUDA's legacy default one, on which a step's CUDA graph
            # could not be captured.
            stream = torch.cuda.Stream(device=self.device)
            torch.cuda.set_stream(stream)
            self.wp.set_stream(self.wp.stream_from_torch(stream), self.batch.device)

    @contextlib.contextmanager
    def _stream(self) -> Iterator[None]:
        with self.wp.ScopedDevice(self.batch.device):
            yield

    def step(self, nstep: int) -> None:
        with self._stream():
            self.batch.advance(nstep)

    def kinematics(self) -> None:
        with self._stream():
            self.mjw.kinematics(self.batch.model, self.batch.data)

    def check_overflow(self) -> None:
        self.batch.check_overflow()

    def commit_model(self) -> None:
        """Nothing to do: ``model`` is Warp's own memory."""

    def diverged(self) -> Any:
        """Worlds whose state is not finite or absurdly fast (Warp carries on with NaN where MuJoCo C resets)."""
        qpos, qvel = self.state["qpos"], self.state["qvel"]
        return ~(qpos.isfinite().all(1) & qvel.isfinite().all(1)) | (qvel.abs() > MAX_SPEED).any(1)

    def clear(self, mask: Any) -> None:
        """Forget the masked worlds' solver warm start (it may hold a diverged world's NaN)."""
        import torch

        warm = self.wp.to_torch(self.batch.data.qacc_warmstart)
        warm.copy_(torch.where(mask.view(-1, 1), torch.zeros_like(warm), warm))


class CPhysics:
    """``nworld`` worlds in MuJoCo C (one MjData each, one model whose randomised parameters are swapped in before
    each world steps), with the float32 tensors ``WarpPhysics`` has. Each MjData keeps its state in double
    precision: a world's qpos or qvel is written back from the tensors only where a task changed them."""

    def __init__(self, mjm: Any, nworld: int) -> None:
        torch = require("torch", "svhdesc.learn", "rl")
        mujoco = require("mujoco", "svhdesc.learn", "rl")
        self._mj = mujoco
        self.nworld, self.mjm = nworld, mjm
        self.device = torch.device("cpu")
        self._datas = [mujoco.MjData(mjm) for _ in range(nworld)]
        self._state = {name: np.stack([_field(d, name) for d in self._datas]) for name in STATE_FIELDS}
        self._read = {name: self._state[name].copy() for name in WRITTEN}  # as last read from MjData
        # geom_aabb: MuJoCo C's (ngeom, 6) as Warp's (ngeom, 2, 3), centre then half-sizes
        self._params = {name: np.stack([_param(mjm, name)] * nworld) for name in MODEL_FIELDS}
        self.state = {name: torch.from_numpy(a) for name, a in self._state.items()}
        self.model = {name: torch.from_numpy(a) for name, a in self._params.items()}
        self._simple = simple_free_bodies(mjm)
        self._bounded = single_geom_bodies(mjm)

    def commit_model(self) -> None:
        """Nothing to do: each world's parameters are swapped into the model as it steps."""

    def _use(self, world: int) -> None:
        for name, array in self._params.items():
            target = getattr(self.mjm, name)
            target[...] = array[world].reshape(target.shape)
        # MuJoCo C takes a simple body's mass matrix from dof_M0 (computed at compile time), not from body_mass:
        # without this, a free cube given 0.71 of its mass fell at 0.71 g. Warp computes it from the body's mass.
        mass, inertia = self._params["body_mass"][world], self._params["body_inertia"][world]
        for body, dof in self._simple:
            self.mjm.dof_M0[dof : dof + 3] = mass[body]
            self.mjm.dof_M0[dof + 3 : dof + 6] = inertia[body]
        # and its broadphase takes a body's bounding box from its BVH (compile time), not from geom_aabb: a box
        # grown by a third sank 9 mm into the table before it touched. A one-geom body's box is its geom's.
        aabb = self._params["geom_aabb"][world]
        for node, geom in self._bounded:
            self.mjm.bvh_aabb[node] = aabb[geom].reshape(6)

    def _run(self, nstep: int, kinematics: bool) -> None:
        for w, d in enumerate(self._datas):
            self._use(w)
            for name in WRITTEN:
                if not np.array_equal(self._state[name][w], self._read[name][w]):
                    getattr(d, name)[:] = self._state[name][w]
            d.ctrl[:] = self._state["ctrl"][w]
            if kinematics:
                self._mj.mj_kinematics(self.mjm, d)
            else:
                self._mj.mj_step(self.mjm, d, nstep)
            for name, array in self._state.items():
                array[w] = _field(d, name)
            for name in WRITTEN:
                self._read[name][w] = self._state[name][w]

    def step(self, nstep: int) -> None:
        self._run(nstep, kinematics=False)

    def kinematics(self) -> None:
        self._run(0, kinematics=True)

    def check_overflow(self) -> None:
        """MuJoCo C has no capacities to overflow: it grows its arena."""

    def diverged(self) -> Any:
        """Worlds MuJoCo C found unstable since the last call (it resets such a world's data and warns)."""
        import torch

        bad = self._mj.mjtWarning.mjWARN_BADQACC
        hit = [d.warning[bad].number > 0 for d in self._datas]
        for d in self._datas:
            d.warning[bad].number = 0
        return torch.tensor(hit) | (self.state["qvel"].abs() > MAX_SPEED).any(1)

    def clear(self, mask: Any) -> None:
        for world in mask.nonzero().flatten().tolist():
            self._datas[world].qacc_warmstart[:] = 0.0

    def data(self, world: int) -> Any:
        """World ``world``'s MjData, with its parameters swapped into ``mjm`` (for rendering)."""
        self._use(world)
        return self._datas[world]


def simple_free_bodies(mjm: Any) -> list[tuple[int, int]]:
    """(body, first dof) of each free-floating body MuJoCo C treats as simple (inertia on its axes)."""
    import mujoco

    free = int(mujoco.mjtJoint.mjJNT_FREE)
    return [
        (int(mjm.jnt_bodyid[j]), int(mjm.jnt_dofadr[j]))
        for j in range(mjm.njnt)
        if int(mjm.jnt_type[j]) == free and int(mjm.body_simple[int(mjm.jnt_bodyid[j])]) == 1
    ]


def single_geom_bodies(mjm: Any) -> list[tuple[int, int]]:
    """(BVH node, geom) of each free body with one geom at its frame's origin, unrotated (a task's objects): the
    node's box is the geom's."""
    import mujoco

    free = {int(mjm.jnt_bodyid[j]) for j in range(mjm.njnt) if int(mjm.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_FREE)}
    found = []
    for body in sorted(free):
        if int(mjm.body_geomnum[body]) != 1 or int(mjm.body_bvhnum[body]) != 1:
            continue
        geom = int(mjm.body_geomadr[body])
        if np.allclose(mjm.geom_pos[geom], 0.0) and np.allclose(mjm.geom_quat[geom], (1.0, 0.0, 0.0, 0.0)):
            found.append((int(mjm.body_bvhadr[body]), geom))
    return found


def _field(data: Any, name: str) -> np.ndarray:
    return np.array(getattr(data, name), dtype=np.float32)


def _param(model: Any, name: str) -> np.ndarray:
    value = np.array(getattr(model, name), dtype=np.float32)
    return value.reshape(-1, 2, 3) if name == "geom_aabb" else value


def make_physics(mjm: Any, nworld: int, device: str, backend: str, nconmax: int, njmax: int) -> Physics:
    """``backend`` "warp" (``device`` cpu or cuda) or "mujoco" (MuJoCo C, on the CPU)."""
    if backend == "warp":
        return WarpPhysics(mjm, nworld, device, nconmax, njmax)
    if backend == "mujoco":
        if device != "cpu":
            raise SvhdescError(f"backend 'mujoco' runs on the CPU, not on device {device!r}")
        return CPhysics(mjm, nworld)
    raise SvhdescError(f"unknown physics backend {backend!r} (known: warp, mujoco)")
