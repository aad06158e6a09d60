"""``usdworld batch`` end to end on a small synthetic Cityscapes tree with one corrupt frame.

In this process and in a local pool; the Dask runs are in test_batch_dask.py.
"""

from __future__ import annotations

import io
import json
import os
import shutil
from pathlib import Path

import pytest
from pxr import Usd, UsdGeom

from usdworld.authoring.validate import errors_only, validate_file
from usdworld.batch import InlineExecutor, LocalPoolExecutor, discover, run_batch
from usdworld.batch.progress import PlainProgress
from usdworld.batch.records import FrameRecord, Journal, read_previous
from usdworld.batch.synthetic import frame_name, write_cityscapes_tree
from usdworld.batch.worker import FrameTask, run_frame
from usdworld.cli.main import main

IDS = [frame_name("synthcity", i) for i in range(5)]
CORRUPT = IDS[2]
#: Record fields that depend on timing or on the process, not on the inputs.
RUN_FIELDS = ("seconds", "cpu_seconds", "worker", "rss_mb", "peak_rss_mb")


def make_dataset(root: Path) -> Path:
    """Five 256 x 128 synthetic Cityscapes frames; the photo of the third is truncated."""
    write_cityscapes_tree(root, 5, width=256, height=128)
    photo = root / "leftImg8bit" / "val" / "synthcity" / f"{CORRUPT}_leftImg8bit.png"
    data = photo.read_bytes()
    photo.write_bytes(data[: len(data) // 2])
    return root


def output_bytes(out: Path) -> dict[str, bytes]:
    """Every file the batch wrote except batch.json (which holds timings)."""
    return {
        p.relative_to(out).as_posix(): p.read_bytes()
        for p in sorted(out.rglob("*"))
        if p.is_file() and p.name != "batch.json"
    }


def stable_records(out: Path) -> list[dict]:
    doc = json.loads((out / "batch.json").read_text())
    return [{k: v for k, v in r.items() if k not in RUN_FIELDS} for r in doc["frames"]]


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return make_dataset(tmp_path_factory.mktemp("cityscapes"))


@pytest.fixture(scope="module")
def inline_out(dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("inline") / "worlds"
    with InlineExecutor() as executor:
        run_batch(discover(dataset, "cityscapes"), out, executor, source="cs", layout="cityscapes")
    return out


def test_corrupt_frame_is_recorded_and_the_rest_built(inline_out: Path) -> None:
    doc = json.loads((inline_out / "batch.json").read_text())
    assert doc["format"] == "usdworld-batch/1"
    assert (doc["source"], doc["layout"], doc["incomplete"]) == ("cs", "cityscapes", [])
    summary = doc["summary"]
    assert {k: summary[k] for k in ("frames", "built", "unchanged", "failed", "cancelled", "incomplete")} == {
        "frames": 5,
        "built": 4,
        "unchanged": 0,
        "failed": 1,
        "cancelled": 0,
        "incomplete": 0,
    }
    assert [(r["frame_id"], r["status"]) for r in doc["frames"]] == [
        (i, "failed" if i == CORRUPT else "built") for i in IDS
    ]
    for r in doc["frames"]:
        assert r["seconds"] > 0 and len(r["key"]) == 64
        assert r["source"] == f"leftImg8bit/val/synthcity/{r['frame_id']}_leftImg8bit.png"
        if r["status"] == "built":
            assert r["objects"] > 0 and r["error"] is None
            assert (inline_out / r["frame_id"] / "world.usda").is_file()
    bad = doc["frames"][2]
    assert (
        bad["objects"] is None
        and "corrupt or truncated" in bad["error"]
        and bad["error"].startswith(f"{CORRUPT}_leftImg8bit.png:")
    )
    assert not (inline_out / CORRUPT).exists()
    assert not (inline_out / ".batch-journal.jsonl").exists()


def test_each_world_is_what_usdworld_build_writes(inline_out: Path, dataset: Path, tmp_path: Path) -> None:
    frame = IDS[1]
    gt, cam = dataset / "gtFine" / "val" / "synthcity", dataset / "camera" / "val" / "synthcity"
    args = [
        "-q", "build", str(dataset / "leftImg8bit" / "val" / "synthcity" / f"{frame}_leftImg8bit.png"),
        "--labels", str(gt / f"{frame}_gtFine_labelIds.png"),
        "--instances", str(gt / f"{frame}_gtFine_instanceIds.png"),
        "--camera", str(cam / f"{frame}_camera.json"),
        "-o", str(tmp_path / "single"),
    ]  # fmt: skip
    assert main(args) == 0
    single = output_bytes(tmp_path / "single")
    assert single == {
        k.split("/", 1)[1]: v for k, v in output_bytes(inline_out).items() if k.startswith(f"{frame}/")
    }


def test_index_opens_with_payloads_unloaded_and_validates(inline_out: Path) -> None:
    path = inline_out / "index.usda"
    stage = Usd.Stage.Open(str(path), Usd.Stage.LoadNone)
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    root = stage.GetDefaultPrim()
    assert root.GetPath().pathString == "/Worlds" and root.IsA(UsdGeom.Xform)
    worlds = root.GetAllChildren()
    built = [i for i in IDS if i != CORRUPT]
    assert [p.GetName() for p in worlds] == built
    for prim, frame in zip(worlds, built):
        assert prim.HasAuthoredPayloads() and not prim.IsLoaded()
        assert prim.GetCustomDataByKey("usdworld:frameId") == frame
        assert (
            prim.GetCustomDataByKey("usdworld:sourceImage")
            == f"leftImg8bit/val/synthcity/{frame}_leftImg8bit.png"
        )
        assert prim.GetAssetInfoByKey("name") == frame
        assert prim.GetAssetInfoByKey("identifier").path == f"./{frame}/world.usda"
    assert stage.GetLoadSet() == []
    assert [layer.identifier for layer in stage.GetUsedLayers() if not layer.anonymous] == [str(path)]
    stage.Load(worlds[0].GetPath())
    assert worlds[0].IsLoaded() and stage.GetPrimAtPath(f"/Worlds/{built[0]}/Objects").IsValid()
    assert errors_only(validate_file(path)) == []


def test_local_pool_gives_the_same_output(inline_out: Path, dataset: Path, tmp_path: Path) -> None:
    out = tmp_path / "pool"
    with LocalPoolExecutor(2) as executor:
        summary = run_batch(discover(dataset, "cityscapes"), out, executor, source="cs", layout="cityscapes")
    assert all(not r.worker.endswith(f":{os.getpid()}") for r in summary.records)  # built in the workers
    assert output_bytes(out) == output_bytes(inline_out)
    assert stable_records(out) == stable_records(inline_out)


def test_resume_rebuilds_only_what_changed(dataset: Path, tmp_path: Path) -> None:
    data = tmp_path / "data"
    shutil.copytree(dataset, data)
    out = tmp_path / "worlds"

    summaries = []

    def run() -> dict[str, str]:
        with InlineExecutor() as executor:
            summaries.append(run_batch(discover(data, "cityscapes"), out, executor, resume=True))
        return {r.frame_id: r.status for r in summaries[-1].records}

    assert run() == {i: "failed" if i == CORRUPT else "built" for i in IDS}
    stamps = {i: (out / i / "layers" / "base.usda").stat().st_mtime_ns for i in IDS if i != CORRUPT}
    built_warnings = {r.frame_id: r.warnings for r in summaries[-1].records}
    report = json.loads((out / IDS[1] / "report.json").read_text())
    report["warnings"].append("an earlier warning")  # the world's report is where they are kept
    (out / IDS[1] / "report.json").write_text(json.dumps(report))
    built_warnings[IDS[1]] += ("an earlier warning",)
    assert run() == {i: "failed" if i == CORRUPT else "unchanged" for i in IDS}
    assert {r.frame_id: r.warnings for r in summaries[-1].records if r.status == "unchanged"} == {
        i: w for i, w in built_warnings.items() if i != CORRUPT
    }
    assert stamps == {i: (out / i / "layers" / "base.usda").stat().st_mtime_ns for i in stamps}
    camera = data / "camera" / "val" / "synthcity" / f"{IDS[3]}_camera.json"
    camera.write_text(camera.read_text().replace('"z": 1.3', '"z": 1.35'))
    assert run() == {i: {CORRUPT: "failed", IDS[3]: "built"}.get(i, "unchanged") for i in IDS}
    assert stamps[IDS[3]] != (out / IDS[3] / "layers" / "base.usda").stat().st_mtime_ns
    assert all(
        stamps[i] == (out / i / "layers" / "base.usda").stat().st_mtime_ns for i in stamps if i != IDS[3]
    )
    doc = json.loads((out / "batch.json").read_text())
    assert doc["summary"]["unchanged"] == 3 and doc["summary"]["built"] == 1
    assert (
        len(Usd.Stage.Open(str(out / "index.usda"), Usd.Stage.LoadNone).GetDefaultPrim().GetAllChildren())
        == 4
    )


def test_resume_reads_the_journal_of_an_interrupted_batch(tmp_path: Path) -> None:
    with Journal(tmp_path) as journal:
        journal.append(FrameRecord("a", "built", 1.0, 3, key="k" * 64))
    with open(tmp_path / ".batch-journal.jsonl", "a") as f:
        f.write('{"frame_id": "b", "sta')  # torn by the interruption
    assert read_previous(tmp_path) == {"a": FrameRecord("a", "built", 1.0, 3, key="k" * 64)}


def test_fail_fast_stops_at_the_first_failure(dataset: Path, tmp_path: Path) -> None:
    with InlineExecutor() as executor:
        summary = run_batch(discover(dataset, "cityscapes"), tmp_path / "w", executor, fail_fast=True)
    assert [r.status for r in summary.records] == ["built", "built", "failed", "cancelled", "cancelled"]
    assert summary.records[3].error == "not run: the batch stopped at the first failure (--fail-fast)"
    assert not (tmp_path / "w" / IDS[3]).exists()


def test_cli_exit_code_and_messages(
    dataset: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "worlds"
    assert main(["batch", str(dataset), "--layout", "cityscapes", "-o", str(out)]) == 1
    captured = capsys.readouterr()
    error = json.loads((out / "batch.json").read_text())["frames"][2]["error"]
    assert captured.err.splitlines()[0] == "batch: 5 frames on this process (1 worker)"
    assert captured.err.splitlines()[-1] == (
        f"error: 1 of 5 frames failed (first: {CORRUPT}: {error}); see {out / 'batch.json'}"
    )
    lines = captured.out.splitlines()
    assert lines[0].startswith("built 4, unchanged 0, failed 1, cancelled 0 of 5 frames in ")
    assert lines[1:] == [
        "failed: 1",
        f"  {CORRUPT}: {error}",
        f"wrote {out / 'batch.json'} and {out / 'index.usda'}",
    ]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (
            [],
            "a folder; pass --layout cityscapes or --layout kitti (it holds leftImg8bit/: --layout cityscapes)",
        ),
        (["--layout", "cityscapes", "--workers", "0"], "--workers must be >= 1, got 0"),
        (
            ["--layout", "cityscapes", "--workers", "2", "--dask-local", "2"],
            "--workers sets a local pool; with --scheduler or --dask-local the cluster's workers run the frames",
        ),
        (
            ["--layout", "kitti"],
            "no image_2/ folder; pass the KITTI object split folder (the one holding image_2/, label_2/ and calib/)",
        ),
        (["--layout", "cityscapes", "--split", "test"], "no split 'test'; found val"),
    ],
)
def test_cli_bad_arguments_exit_2(
    dataset: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], message: str
) -> None:
    assert main(["batch", str(dataset), "-o", str(tmp_path / "w"), *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.rstrip("\n").endswith(message)
    assert not (tmp_path / "w").exists()


def test_cli_manifest_without_complete_frames(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    manifest = tmp_path / "frames.json"
    manifest.write_text('[{"id": "a", "image": "missing.png"}]')
    assert main(["batch", str(manifest), "-o", str(tmp_path / "w")]) == 2
    assert capsys.readouterr().err == (
        f"error: {manifest}: no complete frames found with --layout manifest; 1 incomplete, e.g. "
        f"a: frames.json -> [0] -> image: {tmp_path / 'missing.png'}: no such file\n"
    )


def test_plain_progress_lines() -> None:
    now = [0.0]
    stream = io.StringIO()
    progress = PlainProgress(stream, interval_s=10.0, clock=lambda: now[0])
    progress.start(4, "this process (1 worker)")
    for t, status in ((3.0, "built"), (12.0, "failed"), (15.0, "built")):
        now[0] = t
        progress.update(FrameRecord("f", status))
    progress.close()
    assert stream.getvalue().splitlines() == [
        "batch: 4 frames on this process (1 worker)",
        "batch: 2/4 frames, 1 failed, 0 unchanged, 10.0 frames/min, ETA 0:00:12",
        "batch: 3/4 frames, 1 failed, 0 unchanged, 12.0 frames/min, ETA 0:00:05",
    ]


def test_plain_progress_of_a_resume_gives_the_rate_of_built_frames() -> None:
    now = [0.0]
    stream = io.StringIO()
    progress = PlainProgress(stream, interval_s=100.0, clock=lambda: now[0])
    progress.start(3, "this process (1 worker)")
    for t, status in ((1.0, "unchanged"), (2.0, "unchanged")):
        now[0] = t
        progress.update(FrameRecord("f", status))
    assert progress.line() == "batch: 2/3 frames, 0 failed, 2 unchanged, no frame built yet, ETA 0:00:01"
    now[0] = 6.0
    progress.update(FrameRecord("g", "built"))
    assert progress.line() == "batch: 3/3 frames, 0 failed, 2 unchanged, 10.0 frames/min, ETA 0:00:00"


def test_cli_manifest_row_with_missing_inputs_fails_the_batch(
    dataset: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    image = dataset / "leftImg8bit" / "val" / "synthcity" / f"{IDS[0]}_leftImg8bit.png"
    camera = dataset / "camera" / "val" / "synthcity" / f"{IDS[0]}_camera.json"
    labels = dataset / "gtFine" / "val" / "synthcity" / f"{IDS[0]}_gtFine_labelIds.png"
    manifest = tmp_path / "frames.json"
    good = {"id": "good", "image": str(image), "camera": str(camera), "labels": str(labels)}
    manifest.write_text(json.dumps([good, {"id": "gone", "image": "gone.png"}]))
    out = tmp_path / "w"
    assert main(["batch", str(manifest), "-o", str(out)]) == 1
    captured = capsys.readouterr()
    reason = f"frames.json -> [1] -> image: {tmp_path / 'gone.png'}: no such file"
    assert captured.err.splitlines()[-1] == (
        f"error: 1 of 2 frames failed (first: gone: {reason}); see {out / 'batch.json'}"
    )
    assert captured.out.splitlines()[1:3] == ["failed: 1", f"  gone: {reason}"]
    doc = json.loads((out / "batch.json").read_text())
    assert doc["incomplete"] == [{"name": "gone", "reason": reason, "fails": True}]
    assert [(r["frame_id"], r["status"]) for r in doc["frames"]] == [("good", "built")]


def test_a_dataset_s_partial_frame_is_listed_not_failed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    root = tmp_path / "cs"
    write_cityscapes_tree(root, 2, width=256, height=128)
    (root / "gtFine" / "val" / "synthcity" / f"{IDS[1]}_gtFine_instanceIds.png").unlink()
    assert main(["batch", str(root), "--layout", "cityscapes", "-o", str(tmp_path / "w")]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[1] == "incomplete (not built): 1" and out[2].startswith(f"  {IDS[1]}: ")


def test_manifest_rows_build_the_same_worlds(inline_out: Path, dataset: Path, tmp_path: Path) -> None:
    rel = "data/{kind}/val/synthcity/{frame}{suffix}"
    rows = ["id,image,labels,instances,camera,max_range_m"]
    for frame in IDS[:2]:
        files = [
            rel.format(kind=k, frame=frame, suffix=s)
            for k, s in (
                ("leftImg8bit", "_leftImg8bit.png"),
                ("gtFine", "_gtFine_labelIds.png"),
                ("gtFine", "_gtFine_instanceIds.png"),
                ("camera", "_camera.json"),
            )
        ]
        rows.append(",".join([f"m{frame[-1]}", *files, "80"]))
    shutil.copytree(dataset, tmp_path / "data")
    (tmp_path / "frames.csv").write_text("\n".join(rows) + "\n")
    with InlineExecutor() as executor:
        summary = run_batch(discover(tmp_path / "frames.csv"), tmp_path / "w", executor)
    assert [(r.frame_id, r.status, r.source) for r in summary.records] == [
        ("m0", "built", rel.format(kind="leftImg8bit", frame=IDS[0], suffix="_leftImg8bit.png")),
        ("m1", "built", rel.format(kind="leftImg8bit", frame=IDS[1], suffix="_leftImg8bit.png")),
    ]
    for frame in IDS[:2]:
        mine = output_bytes(tmp_path / "w" / f"m{frame[-1]}")
        assert mine == output_bytes(inline_out / frame)


def test_rich_progress_runs_on_any_stream() -> None:
    from usdworld.batch.progress import RichProgress, make_progress

    stream = io.StringIO()
    assert isinstance(make_progress(stream), PlainProgress)  # not a terminal
    progress = RichProgress(stream)
    progress.start(2, "local pool (2 worker processes, spawn)")
    progress.update(FrameRecord("a", "built"))
    progress.update(FrameRecord("b", "failed", error="x [y] z"))
    progress.close()
    assert "failed b: x [y] z" in stream.getvalue()


@pytest.mark.shared_data
def test_kitti_tree_of_real_frames(
    shared_data: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "kitti"
    frames = sorted(p.stem for p in (shared_data / "kitti" / "training" / "image_2").glob("*.png"))
    n = len(frames)
    assert (
        main(["batch", str(shared_data / "kitti" / "training"), "--layout", "kitti", "-o", str(out)])
        == 0
    )
    assert capsys.readouterr().out.startswith(f"built {n}, unchanged 0, failed 0, cancelled 0 of {n} frames in ")
    stage = Usd.Stage.Open(str(out / "index.usda"), Usd.Stage.LoadNone)
    assert [p.GetName() for p in stage.GetDefaultPrim().GetAllChildren()] == [
        f"frame_{f}" for f in frames
    ]


def crash_on_second_frame(task: FrameTask) -> FrameRecord:
    """Stand-in worker function (runs in the pool's processes): the second frame kills its process."""
    if task.frame_id == IDS[1]:
        os._exit(3)
    return run_frame(task)


def test_a_dying_worker_fails_its_frames_and_the_batch_goes_on(
    dataset: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from usdworld.batch import executors

    monkeypatch.setattr(executors, "run_frame", crash_on_second_frame)
    with LocalPoolExecutor(1) as executor:
        summary = run_batch(discover(dataset, "cityscapes"), tmp_path / "w", executor)
    status = {r.frame_id: r.status for r in summary.records}
    crashed = {r.frame_id for r in summary.records if r.error and "worker process died" in r.error}
    assert status[IDS[0]] == "built" and status[IDS[4]] == "built"  # a fresh pool carried on
    assert IDS[1] in crashed and crashed <= {IDS[1], IDS[2], IDS[3]}  # only frames in flight with it
    assert status[CORRUPT] == "failed"


def test_a_dead_builds_temporary_folder_is_removed_once_its_frame_has_a_record(
    dataset: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """A worker killed mid-build (a Dask worker crash) leaves ``.<frame>.tmp-XXXX``; the batch removes
    it once every frame has its record, and only the leftovers of its own frames."""
    out = tmp_path / "worlds"
    dead = out / f".{IDS[1]}.tmp-deadbeef"
    (dead / "layers").mkdir(parents=True)
    (dead / "layers" / "base.usda").write_text("#usda 1.0\n")
    other = out / ".not_a_frame_of_this_batch.tmp-1234abcd"
    other.mkdir()
    lookalike = out / f".{IDS[2]}.tmp-file"  # a file, not a build's folder
    lookalike.write_text("kept")
    with caplog.at_level("WARNING", logger="usdworld.batch.runner"), InlineExecutor() as executor:
        run_batch(discover(dataset, "cityscapes"), out, executor, source="cs", layout="cityscapes")
    assert not dead.exists()
    assert other.is_dir() and lookalike.read_text() == "kept"
    assert sorted(p.name for p in out.iterdir() if p.name.startswith(".")) == sorted([other.name, lookalike.name])
    assert [r.getMessage() for r in caplog.records if "left by a build" in r.getMessage()] == [
        f"{IDS[1]}: removed {dead.name}, left by a build whose process died"
    ]
