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

from usdworld.batch import LocalPoolExecutor, discover, run_batch
from usdworld.batch.dask_executor import (
    INSTALL_HINT,
    MALLOC_TRIM,
    MAX_FRAMES_PER_TASK,
    ClusterError,
    DaskExecutor,
    frames_per_task,
)
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


def _worker_settings() -> dict[str, object]:
    import dask

    return {
        "profile": dask.config.get("distributed.worker.profile.enabled"),
        "tick": dask.config.get("distributed.admin.tick.interval"),
        "malloc_trim": os.environ.get(MALLOC_TRIM),
        "omp_threads": os.environ.get("OMP_NUM_THREADS"),
    }


def test_an_existing_cluster_keeps_its_configuration(cluster: object, tmp_path: Path) -> None:
    import dask

    spawn_env = dask.config.get("distributed.nanny.pre-spawn-environ")  # the cluster was started with these
    expected = {
        "profile": dask.config.get("distributed.worker.profile.enabled"),  # True by default
        "tick": dask.config.get("distributed.admin.tick.interval"),  # 20ms by default
        "malloc_trim": str(spawn_env[MALLOC_TRIM]),  # 65536 by default
        "omp_threads": str(spawn_env["OMP_NUM_THREADS"]),
    }
    address = cluster.scheduler_address  # type: ignore[attr-defined]
    with DaskExecutor(address, out_dir=tmp_path) as executor:
        settings = list(executor.client.run(_worker_settings).values())
    assert settings == 2 * [expected]


def test_frames_in_one_dask_task_give_the_same_worlds(
    cluster: object, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    data = make_dataset(tmp_path / "data")
    with LocalPoolExecutor(2) as pool:
        run_batch(discover(data, "cityscapes"), tmp_path / "pool", pool, source="cs", layout="cityscapes")
    monkeypatch.setattr(DaskExecutor, "_slots", lambda self: 1)  # one frame, then the other four in one task
    sizes: list[int] = []

    def recorded_frames_per_task(recent: list[float], task_seconds: float) -> int:
        sizes.append(frames_per_task(recent, task_seconds))
        return sizes[-1]

    monkeypatch.setattr("usdworld.batch.dask_executor.frames_per_task", recorded_frames_per_task)
    address = cluster.scheduler_address  # type: ignore[attr-defined]
    with DaskExecutor(address, out_dir=tmp_path, task_seconds=1000.0) as executor:
        summary = run_batch(
            discover(data, "cityscapes"), tmp_path / "dask", executor, source="cs", layout="cityscapes"
        )
    assert sizes[:2] == [1, MAX_FRAMES_PER_TASK]
    assert len({r.worker for r in summary.records[1:]}) == 1  # the last four frames: one task, one worker
    assert [(r.frame_id, r.status) for r in summary.records] == [
        (i, "failed" if i == CORRUPT else "built") for i in IDS
    ]
    assert output_bytes(tmp_path / "dask") == output_bytes(tmp_path / "pool")
    assert stable_records(tmp_path / "dask") == stable_records(tmp_path / "pool")


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
    records = json.loads((dask / "batch.json").read_text())["frames"]
    assert [(r["frame_id"], r["status"]) for r in records] == [
        (i, "failed" if i == CORRUPT else "built") for i in IDS
    ]
    assert stable_records(dask) == stable_records(pool)
    assert output_bytes(dask) == output_bytes(pool)  # every layer, asset, report.json and index.usda
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
    summary = json.loads((out / "batch.json").read_text())["summary"]
    assert [summary[k] for k in ("frames", "built", "unchanged", "failed", "cancelled")] == [5, 0, 4, 1, 0]
    assert "built 0" not in capsys.readouterr().out  # -q: no results line, only the failures


def test_unreachable_scheduler_is_a_one_line_error() -> None:
    if distributed is None:
        pytest.fail(f"dask.distributed is not installed; these tests need it: {INSTALL_HINT}")
    with pytest.raises(
        ClusterError,
        match=r"^tcp://127.0.0.1:9: cannot reach the Dask scheduler .*start one with `dask scheduler`",
    ):
        DaskExecutor("tcp://127.0.0.1:9", timeout_s=1).__enter__()


def test_dask_local_cluster_is_tuned_and_this_process_is_not(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    if distributed is None:
        pytest.fail(f"dask.distributed is not installed; these tests need it: {INSTALL_HINT}")
    import dask

    monkeypatch.delenv(MALLOC_TRIM, raising=False)  # a nanny started earlier in this process leaves it set
    monkeypatch.delenv("OMP_NUM_THREADS", raising=False)
    before = dask.config.get("distributed.worker.profile.enabled")
    with DaskExecutor(local_workers=1, out_dir=tmp_path) as executor:
        settings = list(executor.client.run(_worker_settings).values())
    # Dask's other pre-spawn-environ (OMP_NUM_THREADS=1 ...) still reaches the workers
    assert settings == [{"profile": False, "tick": "1s", "malloc_trim": None, "omp_threads": "1"}]
    assert dask.config.get("distributed.worker.profile.enabled") == before
    assert MALLOC_TRIM not in os.environ and "OMP_NUM_THREADS" not in os.environ  # nor this process


@pytest.mark.parametrize(
    ("recent", "task_seconds", "expected"),
    [
        ([], 0.5, 1),  # nothing finished yet: one frame per task
        ([0.1, 0.1, 0.2], 0.5, 5),  # median 0.1 s
        ([0.12, 0.13, 0.11], 0.5, 4),  # floor(0.5 / 0.12)
        ([0.3], 0.5, 1),
        ([2.0, 3.0], 0.5, 1),  # slow frames: one per task
        ([0.001], 0.5, MAX_FRAMES_PER_TASK),  # e.g. --resume finding unchanged frames
        ([0.0], 0.5, MAX_FRAMES_PER_TASK),
        ([0.1], 0.0, 1),  # task_seconds 0: one frame per task
    ],
)
def test_frames_per_task(recent: list[float], task_seconds: float, expected: int) -> None:
    assert frames_per_task(recent, task_seconds) == expected
