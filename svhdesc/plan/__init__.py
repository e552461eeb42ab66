"""Motion planning on a variant's generated MoveIt config, as MoveIt's OMPL pipeline would plan it.

```python
from svhdesc.plan import Planner, Obstacle
planner = Planner("ur5_svh_right", [Obstacle("table", "box", (0.4, 0.3, 0.02), (0.0, 0.55, -0.02))])
plan = planner.plan("manipulator", "home", goal="test")          # or pose=(x, y, z, roll, pitch, yaw)
plan.success, plan.planning_time, plan.joint_names, plan.times, plan.positions
```

Reads only the generated MoveIt config (SRDF, joint_limits.yaml, kinematics.yaml, moveit_controllers.yaml),
the URDF (position limits, IK) and the simulation's scene.xml (the robot's MJCF with the floor and pedestal:
collision checking with MuJoCo, docs/plan.md).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from svhdesc.errors import SvhdescError
from svhdesc.model import get
from svhdesc.plan.config import MoveItConfig, load_config
from svhdesc.plan.planner import PLANNERS, Plan, plan_motion, seed_ompl
from svhdesc.plan.scene import CollisionScene
from svhdesc.sim.objects import Obstacle

__all__ = ["Planner", "Plan", "Obstacle", "PLANNERS", "seed_ompl", "MoveItConfig"]

StateSpec = str | Sequence[float] | Mapping[str, float]


class Planner:
    def __init__(self, variant: str, obstacles: Sequence[Obstacle] = ()) -> None:
        model = get(variant)
        self.variant = variant
        self.config = load_config(model.directory, variant)
        self.scene = CollisionScene(variant, self.config, obstacles)
        self._kinematics = None

    def default_rest(self) -> dict[str, float]:
        """Where joints outside the planned group are: the SRDF's 'home' state (else 0)."""
        rest = {j: 0.0 for joints in self.config.groups.values() for j in joints if j not in self.config.passive}
        for states in self.config.group_states.values():
            rest.update(states.get("home", {}))
        return rest

    def resolve(self, group: str, spec: StateSpec, rest: Mapping[str, float] | None = None) -> dict[str, float]:
        """A full robot state: ``rest`` (default: home) with ``group``'s joints from ``spec`` -- a group
        state name, its values in the group's joint order (a list or "a,b,c"), or a joint -> value map."""
        joints = self.config.active(group)
        state = dict(self.default_rest() if rest is None else rest)
        if isinstance(spec, Mapping):
            state.update(spec)
            return state
        if isinstance(spec, str) and "," not in spec:
            named = self.config.state(group, spec)
            for states in self.config.group_states.values():  # the whole state, hand included
                if spec in states and set(joints) <= set(states[spec]):
                    state.update(states[spec])
            state.update(named)
            return state
        text = spec.split(",") if isinstance(spec, str) else spec
        try:
            values = [float(v) for v in text]
        except ValueError:
            raise SvhdescError(f"state '{spec}': expected a group state name or {len(joints)} numbers") from None
        if len(values) != len(joints):
            raise SvhdescError(f"state '{spec}': {len(values)} values for the {len(joints)} joints of '{group}'")
        state.update(zip(joints, values))
        return state

    def kinematics(self) -> object:
        if self._kinematics is None:
            from svhdesc.plan.ik import Kinematics

            self._kinematics = Kinematics(self.variant, self.config)
        return self._kinematics

    def plan(
        self,
        group: str,
        start: StateSpec,
        goal: StateSpec | None = None,
        pose: Sequence[float] | None = None,
        planner: str = "RRTConnect",
        timeout: float = 5.0,
        velocity_scaling: float | None = None,
        acceleration_scaling: float | None = None,
        rest: Mapping[str, float] | None = None,
    ) -> Plan:
        if (goal is None) == (pose is None):
            raise SvhdescError("give a goal state or a pose, not both")
        joints = self.config.active(group)
        begin = self.resolve(group, start, rest)
        first = [begin[j] for j in joints]
        if pose is not None:
            if len(pose) != 6:
                raise SvhdescError(f"--pose needs X Y Z ROLL PITCH YAW, got {len(pose)} numbers")
            last = self.kinematics().solve(group, pose, begin, first, self.scene)
        else:
            end = self.resolve(group, goal, begin)
            last = [end[j] for j in joints]
        return plan_motion(
            self.scene, self.config, group, begin, first, last, planner, timeout, velocity_scaling, acceleration_scaling
        )
