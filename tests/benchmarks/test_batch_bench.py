"""benchmarks/batch_bench.py names each GPU's page by the card, so one card's rows never overwrite another's.

Seeded fault: ``gpu_tag`` returning ``"_gpu"`` alone -> the H100 and H200 pages collide and the test fails.
"""

from __future__ import annotations

from tests.benchmarks.scripts import REPO, load


def test_each_gpu_model_gets_its_own_page() -> None:
    bench = load("batch_bench")
    assert bench.page_name("svh_right", None, False) == "batch"  # the CPU default page
    h100 = bench.page_name("svh_right", "NVIDIA H100 80GB HBM3", False)
    h200 = bench.page_name("svh_right", "NVIDIA H200", False)
    assert h100 == "batch_gpu_h100"
    assert h200 == "batch_gpu_h200"
    assert bench.page_name("ur5_svh_right", "NVIDIA H100 80GB HBM3", True, 2200) == (
        "batch_ur5_svh_right_gpu_h100_grasp_njmax2200"
    )
    assert bench.page_name("svh_right", "NVIDIA A100-SXM4-40GB", False) == "batch_gpu_a100"
    assert bench.page_name("svh_right", "some card", False) == "batch_gpu"  # no model number: the plain name
    written = {p.stem for p in (REPO / "docs" / "results").glob("batch_gpu*.md")}
    assert {h100, h200} <= written  # the pages the README and docs/speed.md link
