"""OMPL planning for ``manipulator`` on ur5_svh_right among a table and a box, checked independently.

    python benchmarks/plan_bench.py [N] [PLANNER]      # N random queries (default 100), planner (RRTConnect)

Start and goal states are drawn uniformly within the joint limits with shoulder_lift_joint in [-pi, 0] (the
working half: below it the floor and the pedestal split the joint space), seeded, until both are collision-free
for the planner's checker (MuJoCo). Each query may take 5 s. The same over the whole joint limits is printed
beside, with up to 3 of its failures tried again for 30 s each. Printed: success rate (target >= 95 %), median and
90th-percentile planning time (target: median <= 0.5 s on 2 cores), median joint-space path length and
trajectory duration. Then every planned path is re-checked by a checker that shares no code with the
planner: pinocchio + coal on the URDF's collision meshes with the SRDF's disabled pairs removed, the
obstacles as coal boxes, the path subdivided until no frame of the robot moves more than 1 cm between two
checked states. Writes docs/results/plan.md. Not a test: machines are noisy.
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import svhdesc  # noqa: E402
from svhdesc.plan import Obstacle, Planner, seed_ompl  # noqa: E402

sys.path.insert(0, str(REPO / "benchmarks"))
from results import write  # noqa: E402

VARIANT = "ur5_svh_right"
TABLE = Obstacle("table", "box", (0.5, 0.3, 0.02), (0.0, 0.6, -0.02))  # top at z = 0, 0.3 m in front
BOX = Obstacle("box", "box", (0.08, 0.08, 0.12), (0.25, 0.5, 0.12))  # on the table
RESOLUTION = 0.01  # m


class IndependentChecker:
    """pinocchio + coal, from the URDF and SRDF alone."""

    def __init__(self, obstacles: list[Obstacle]) -> None:
        import coal
        import pinocchio as pin

        self.pin = pin
        robot = svhdesc.load_pinocchio(VARIANT, mimic=True)
        self.model, self.geometry = robot.model, robot.collision_model
        robot_geometries = len(self.geometry.geometryObjects)
        self.geometry.addAllCollisionPairs()
        srdf = svhdesc.get(VARIANT).directory / "config" / f"{VARIANT}.srdf"
        pin.removeCollisionPairs(self.model, self.geometry, str(srdf))
        for obstacle in obstacles:
            placement = pin.SE3(np.eye(3), np.array(obstacle.position))
            shape = coal.Box(*(2 * np.array(obstacle.size)))
            index = self.geometry.addGeometryObject(pin.GeometryObject(obstacle.name, 0, 0, placement, shape))
            for other in range(robot_geometries):
                if self.geometry.geometryObjects[other].parentJoint != 0:
                    self.geometry.addCollisionPair(pin.CollisionPair(other, index))
        self.data = self.model.createData()
        self.geometry_data = pin.GeometryData(self.geometry)
        self.checks = 0
        # Geometries below wrist_3 (the hand on the flange) keep their relative poses while only the arm
        # moves: their pairs are checked once per path (in full_check), not at every state.
        wrist = self.model.getJointId("wrist_3_joint")
        rigid = {j for j in range(self.model.njoints) if wrist in self.model.supports[j].tolist()}
        parent = [g.parentJoint for g in self.geometry.geometryObjects]
        self.constant = [
            k
            for k, pair in enumerate(self.geometry.collisionPairs)
            if parent[pair.first] in rigid and parent[pair.second] in rigid
        ]
        self._constant_pairs(False)

    def _constant_pairs(self, active: bool) -> None:
        switch = self.geometry_data.activateCollisionPair if active else self.geometry_data.deactivateCollisionPair
        for k in self.constant:
            switch(k)

    def full_check(self, q: np.ndarray) -> bool:
        self._constant_pairs(True)
        try:
            return self.collides(q)
        finally:
            self._constant_pairs(False)

    def q(self, joints: list[str], values: np.ndarray) -> np.ndarray:
        q = self.pin.neutral(self.model)
        for name, value in zip(joints, values):
            q[self.model.joints[self.model.getJointId(name)].idx_q] = value
        return q

    def collides(self, q: np.ndarray) -> bool:
        self.checks += 1
        return bool(self.pin.computeCollisions(self.model, self.data, self.geometry, self.geometry_data, q, True))

    def frames(self, q: np.ndarray) -> np.ndarray:
        self.pin.framesForwardKinematics(self.model, self.data, q)
        return np.array([f.translation for f in self.data.oMf])

    def path_collides(self, joints: list[str], waypoints: list[list[float]]) -> bool:
        if self.full_check(self.q(joints, np.array(waypoints[0]))):
            return True
        for a, b in zip(waypoints, waypoints[1:]):
            if self._segment(self.q(joints, np.array(a)), self.q(joints, np.array(b)), self.frames(self.q(joints, a))):
                return True
        return self.collides(self.q(joints, np.array(waypoints[-1])))

    def _segment(self, a: np.ndarray, b: np.ndarray, frames_a: np.ndarray) -> bool:
        stack = [(a, b, frames_a)]
        while stack:
            qa, qb, fa = stack.pop()
            fb = self.frames(qb)
            if np.linalg.norm(fb - fa, axis=1).max() > RESOLUTION:
                mid = 0.5 * (qa + qb)
                fm = self.frames(mid)
                stack.append((mid, qb, fm))
                stack.append((qa, mid, fa))
                continue
            if self.collides(qa):
                return True
        return False


def queries(scene: object, index: np.ndarray, lower: np.ndarray, upper: np.ndarray, count: int, seed: int) -> list:
    """``count`` (start, goal) pairs of collision-free states drawn uniformly within [lower, upper]."""
    rng = np.random.default_rng(seed)

    def free() -> list[float]:
        while True:
            q = rng.uniform(lower, upper)
            if scene.valid(index, q):
                return q.tolist()

    return [(free(), free()) for _ in range(count)]


def solve(planner: Planner, pairs: list, planner_name: str, rest: dict[str, float]) -> tuple[list, float]:
    """Every pair planned with 5 s each; the plans and the wall time for all."""
    began = time.perf_counter()
    plans = [
        planner.plan("manipulator", start, goal=goal, planner=planner_name, timeout=5.0, rest=rest)
        for start, goal in pairs
    ]
    return plans, time.perf_counter() - began


def main(count: int = 100, planner_name: str = "RRTConnect") -> None:
    seed_ompl(7)
    obstacles = [TABLE, BOX]
    planner = Planner(VARIANT, obstacles)
    config, scene = planner.config, planner.scene
    joints = config.active("manipulator")
    rest = planner.default_rest()
    scene.set_state(rest)
    index = scene.joint_index(joints)
    lower = np.array([config.lower[j] for j in joints])
    upper = np.array([config.upper[j] for j in joints])
    # The working half: the upper arm at or above the shoulder's horizontal (shoulder_lift in [-pi, 0]). Below
    # it the arm reaches into the floor and the pedestal, which split the +-2 pi joint space into regions no path
    # joins (a query drawn across them has no solution: the 5 such failures tried with 30 s all failed).
    half_lower, half_upper = lower.copy(), upper.copy()
    lift = joints.index("shoulder_lift_joint")
    half_lower[lift], half_upper[lift] = max(lower[lift], -np.pi), min(upper[lift], 0.0)
    pairs = queries(scene, index, half_lower, half_upper, count, 2024)
    plans, wall = solve(planner, pairs, planner_name, rest)
    anywhere = queries(scene, index, lower, upper, count, 2024)
    anywhere_plans, anywhere_wall = solve(planner, anywhere, planner_name, rest)
    done = [p for p in plans if p.success]
    times = sorted(p.planning_time for p in plans)
    median, p90 = statistics.median(times), times[int(0.9 * (len(times) - 1))]
    print(f"{len(done)}/{count} solved; planning time median {median:.3f} s, 90th percentile {p90:.3f} s")
    checker = IndependentChecker(obstacles)
    # The checker must see collisions: the straight motion of a query that needed a detour.
    for start, goal in pairs:
        a, b = np.array(start), np.array(goal)
        steps = int(np.ceil(np.abs(b - a).max() / 0.01))
        if not all(scene.valid(index, a + (b - a) * k / steps) for k in range(steps + 1)):
            flagged = checker.path_collides(joints, [start, goal])
            print(f"independent checker flags a straight motion MuJoCo finds colliding: {flagged}")
            break
    began = time.perf_counter()
    colliding = [i for i, p in enumerate(done) if checker.path_collides(joints, p.waypoints)]
    recheck = time.perf_counter() - began
    length = f"{statistics.median(p.path_length for p in done):.1f} rad" if done else "-"
    duration = f"{statistics.median(p.duration for p in done):.1f} s" if done else "-"
    solved_anywhere = sum(p.success for p in anywhere_plans)
    anywhere_median = statistics.median(p.planning_time for p in anywhere_plans)
    failed = [pair for pair, plan in zip(anywhere, anywhere_plans) if not plan.success][:3]
    retried = [planner.plan("manipulator", a, goal=b, planner=planner_name, timeout=30.0, rest=rest) for a, b in failed]
    body = [
        f"{count} random collision-free start and goal states of `manipulator` (`{VARIANT}`, uniform within its "
        f"joint limits with `shoulder_lift_joint` in [-pi, 0], the working half) among a table and a box, "
        f"{planner_name}, 5 s per query ({wall:.0f} s for all):",
        "",
        f"| success | planning time, median (target <= 0.5 s) | 90th percentile | path length, median "
        f"| trajectory, median | independent re-check ({RESOLUTION * 100:.0f} cm) |",
        "|---|---|---|---|---|---|",
        f"| {len(done)}/{count} (target >= 95 %) | {median:.3f} s | {p90:.3f} s | {length} | {duration} "
        f"(joint_limits.yaml's default scaling) | {len(done) - len(colliding)}/{len(done)} paths collision-free, "
        f"{checker.checks} states, {recheck:.0f} s |",
        "",
        f"Drawn anywhere within the joint limits instead ({count} other pairs, {anywhere_wall:.0f} s for all): "
        f"{solved_anywhere}/{count} solved, median {anywhere_median:.3f} s; {sum(p.success for p in retried)} of "
        f"{len(retried)} failures solved when tried again with 30 s. Below the shoulder's horizontal the arm",
        "reaches into the floor and the pedestal of the simulation's scene, which split the +-2 pi joint space into",
        "regions no path joins: a pair drawn across them has no solution.",
        "",
        "The re-check: pinocchio + coal on the URDF's collision meshes with the SRDF's disabled pairs removed, the",
        f"path subdivided until no frame moves more than {RESOLUTION * 100:.0f} cm between two checked states; the "
        f"pairs rigid in the hand ({len(checker.constant)} of {len(checker.geometry.collisionPairs)}) once per path",
        "([plan.md](/docs/plan.md#benchmark)).",
    ]
    if colliding:
        body += ["", f"Paths the re-check finds colliding (query numbers): {colliding}."]
    print("\n".join(body))
    path = write("plan", "Motion planning benchmark", body)
    print(f"wrote {path.relative_to(REPO)}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 100, sys.argv[2] if len(sys.argv) > 2 else "RRTConnect")
