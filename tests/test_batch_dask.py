"""``usdworld batch`` on a real Dask cluster (``dask.distributed.LocalCluster``, 2 worker processes).

Marked ``dask`` (``pytest -m dask`` runs only these). They run in CI, which installs
``dask[distributed]``; without it they fail with the install hint instead of skipping.
"""

from __future__ import annotations

import json
import logging
import os
from pathlib import Path

import pytest
from test_batch_run import CORRUPT, IDS, make_dataset, output_bytes, stable_records

from usdworld.batch.dask_executor import INSTALL_HINT, ClusterError, DaskExecutor
from usdworld.cli.main import main

pytestmark = pytest.mark.dask

try:
    import distributed
except ImportError:  # pragma: no cover - CI installs it
    distributed = None


@pytest.fixture(scope="module")
def cluster() -> object:
    if distributed is None:
        pytest.fail(f"dask.distributed is not installed; these tests need it: {INSTALL_HINT}")
    options = {
        "threads_per_worker": 1,
        "processes": True,
        "dashboard_address": ":0",
        "silence_logs": logging.ERROR,
    }
    with distributed.LocalCluster(n_workers=2, **options) as local:
        yield local


def test_dask_cluster_and_local_pool_give_identical_worlds(
    cluster: object, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = make_dataset(tmp_path / "data")
    pool, dask = tmp_path / "pool", tmp_path / "dask"
    base = ["batch", str(data), "--layout", "cityscapes"]
    assert main([*base, "-o", str(pool), "--workers", "2"]) == 1
    assert main([*base, "-o", str(dask), "--scheduler", cluster.scheduler_address]) == 1  # type: ignore[attr-defined]
    err = capsys.readouterr().err
    assert f"batch: 5 frames on Dask scheduler {cluster.scheduler_address}" in err  # type: ignore[attr-defined]
    assert output_bytes(dask) == output_bytes(pool)  # every layer, asset, report.json and index.usda
    assert stable_records(dask) == stable_records(pool)
    records = json.loads((dask / "batch.json").read_text())["frames"]
    assert [(r["frame_id"], r["status"]) for r in records] == [
        (i, "failed" if i == CORRUPT else "built") for i in IDS
    ]
    assert len(cluster.workers) == 2  # type: ignore[attr-defined]
    assert all(not r["worker"].endswith(f":{os.getpid()}") for r in records)  # built in the Dask workers


def test_dask_local_option_and_resume(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    if distributed is None:
        pytest.fail(f"dask.distributed is not installed; these tests need it: {INSTALL_HINT}")
    data = make_dataset(tmp_path / "data")
    out = tmp_path / "worlds"
    args = ["-q", "batch", str(data), "--layout", "cityscapes", "-o", str(out), "--dask-local", "2"]
    assert main(args) == 1
    assert main([*args, "--resume"]) == 1
    assert "built 0, unchanged 4, failed 1, cancelled 0 of 5 frames" in capsys.readouterr().out


def test_unreachable_scheduler_is_a_one_line_error() -> None:
    if distributed is None:
        pytest.fail(f"dask.distributed is not installed; these tests need it: {INSTALL_HINT}")
    with pytest.raises(
        ClusterError,
        match=r"^tcp://127.0.0.1:9: cannot reach the Dask scheduler .*start one with `dask scheduler`",
    ):
        DaskExecutor("tcp://127.0.0.1:9", timeout_s=1).__enter__()
