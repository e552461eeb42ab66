"""rsl-rl's multi-GPU scheme (torch.distributed under ``torchrun``), run as two processes on the CPU (gloo, in a
private network namespace, 127.0.0.1): rank 0 alone prints and writes, the env-steps count both ranks' worlds, and
the two ranks end with identical actors though each stepped its own worlds.

Seeded fault: svhdesc's Runner leaving ``cfg["multi_gpu"]`` unset on the CPU (rsl-rl's PPO then averages no
gradients): the ranks' actors differ and training ends with ``error: the 2 ranks' actors differ``.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.netns import private_namespace
from tests.support import REPO

pytest.importorskip("torch")
pytest.importorskip("rsl_rl")

pytestmark = pytest.mark.slow


def test_two_ranks_on_the_cpu(tmp_path: Path) -> None:
    unshare = private_namespace()
    if isinstance(unshare, str):
        pytest.skip(unshare)
    out = tmp_path / "run"
    torchrun = (
        f"{sys.executable} -m torch.distributed.run --nnodes 1 --nproc_per_node 2 --rdzv-backend static "
        "--master-addr 127.0.0.1 --master-port 29511 -m svhdesc.cli train svh_reach --backend mujoco --envs 8 "
        f"--iterations 2 --out {out}"
    )
    result = subprocess.run(
        [*unshare, "sh", "-c", f"ip link set lo up && exec {torchrun}"],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=REPO,
        env={**os.environ, "GLOO_SOCKET_IFNAME": "lo", "PYTHONPATH": str(REPO)},
    )
    assert result.returncode == 0, result.stderr[-3000:]
    lines = result.stdout.splitlines()
    assert sum(line.startswith("training svh_reach") for line in lines) == 1, lines  # rank 0 speaks
    progress = [line for line in lines if line.startswith("it ")]
    assert [line.split()[3] for line in progress] == ["256", "512"], progress  # 2 ranks x 8 worlds x 16 steps
    assert "actor parameters identical on all 2 ranks" in lines
    assert sorted(p.name for p in out.glob("model_*.pt")) == ["model_0.pt", "model_1.pt"]
    assert (out / "policy.onnx").is_file()
