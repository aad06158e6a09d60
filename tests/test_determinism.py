"""Bit-for-bit determinism: the same frame gives the same bytes in every process and thread setting.

The frame is small (640 x 360) but gives the camera's height and pitch free (its camera file
holds only K), so the build sums the camera posterior over its full (height, pitch) grid of
~26,000 points: the sum that used to go through a threaded BLAS dot product and change in its
last bits with ``OPENBLAS_NUM_THREADS``. Every file of the world folder is compared, binary
ground layer and assets included.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
from test_batch_run import output_bytes, stable_records

from usdworld.cli.main import main
from usdworld.pipeline import BuildRequest, build

REPO = Path(__file__).resolve().parents[1]

DETECTIONS = """\
Car 0.00 0 0.0 250.0 170.0 390.0 242.0 0 0 0 0 0 0 0
Pedestrian 0.00 0 0.0 470.0 150.0 492.0 212.0 0 0 0 0 0 0 0
Car 0.00 0 0.0 100.0 168.0 170.0 200.0 0 0 0 0 0 0 0
"""

#: Builds one world from argv[1:] = image, detections, camera, output (a subprocess's own BLAS threads).
BUILD_SCRIPT = """\
import sys
from pathlib import Path
from usdworld.pipeline import BuildRequest, build
image, detections, camera, output = map(Path, sys.argv[1:])
build(BuildRequest(image=image, detections=detections, camera=camera, output=output))
"""


def write_frame(folder: Path) -> dict[str, Path]:
    """A grey street photo with two cars and a pedestrian, KITTI labels and a K-only camera file."""
    folder.mkdir(parents=True, exist_ok=True)
    image = np.full((360, 640, 3), 96, dtype=np.uint8)
    image[180:] = 60
    cv2.imwrite(str(folder / "frame.png"), image)
    (folder / "frame.txt").write_text(DETECTIONS)
    camera = {"K": [[500.0, 0.0, 320.0], [0.0, 500.0, 170.0], [0.0, 0.0, 1.0]]}
    (folder / "camera.json").write_text(json.dumps(camera))
    return {
        "image": folder / "frame.png",
        "detections": folder / "frame.txt",
        "camera": folder / "camera.json",
    }


def world_bytes(world: Path) -> dict[str, bytes]:
    """Every file of a world folder by its relative path."""
    files = {p.relative_to(world).as_posix(): p.read_bytes() for p in sorted(world.rglob("*")) if p.is_file()}
    assert "layers/base.usda" in files and "report.json" in files
    return files


def build_in_subprocesses(inputs: dict[str, Path], outputs: dict[str, dict[str, str]]) -> None:
    """Build the frame once per output folder, concurrently, each in a process with its own environment."""
    procs = []
    for output, env in outputs.items():
        args = [str(inputs["image"]), str(inputs["detections"]), str(inputs["camera"]), output]
        full_env = {**os.environ, "PYTHONPATH": str(REPO), **env}
        procs.append(
            subprocess.Popen(
                [sys.executable, "-c", BUILD_SCRIPT, *args], env=full_env, stderr=subprocess.PIPE, text=True
            )
        )
    for proc in procs:
        _, err = proc.communicate(timeout=300)
        assert proc.returncode == 0, err


#: Prints the bits of a homography fit at the pair cap and of a camera estimate with height and
#: pitch free, computed in this subprocess (with the BLAS threads its environment sets).
GEOMETRY_SCRIPT = """\
import numpy as np
from usdworld.geometry.estimate import HeightObservations, estimate_camera
from usdworld.geometry.homography import estimate_homography
from usdworld.io.limits import MAX_GROUND_PAIRS
rng = np.random.default_rng(7)
px = rng.uniform([0, 200], [1240, 370], (MAX_GROUND_PAIRS, 2))
ground = rng.uniform([5, -20], [80, 20], (MAX_GROUND_PAIRS, 2))
fit = estimate_homography(px, ground)
print(fit.dst_from_src.tobytes().hex(), fit.rms_src.hex(), fit.rms_dst.hex())
n = 12
obs = HeightObservations(rng.uniform(100, 1100, n), rng.uniform(200, 360, n), rng.uniform(150, 190, n),
                         np.full(n, 1.5), np.full(n, 0.1))
K = np.array([[720.0, 0, 610], [0, 720, 173], [0, 0, 1]])
est = estimate_camera(1242, 375, K, None, None, None, None, obs)
print(est.camera.height_m.hex(), est.camera.pitch.hex(), est.sigma_height_m.hex(), est.sigma_pitch.hex())
"""


def test_homography_and_camera_estimate_do_not_depend_on_blas_threads() -> None:
    """The DLT at its pair cap and the camera posterior, bit for bit, with 1 and 2 BLAS threads."""
    outputs = []
    for threads in ("1", "2"):
        env = {
            **os.environ,
            "PYTHONPATH": str(REPO),
            "OPENBLAS_NUM_THREADS": threads,
            "OMP_NUM_THREADS": threads,
        }
        done = subprocess.run(
            [sys.executable, "-c", GEOMETRY_SCRIPT],
            env=env,
            capture_output=True,
            text=True,
            timeout=300,
            check=False,
        )
        assert done.returncode == 0, done.stderr
        outputs.append(done.stdout)
    assert outputs[0] == outputs[1]


@pytest.fixture(scope="module")
def frame(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return write_frame(tmp_path_factory.mktemp("frame"))


@pytest.fixture(scope="module")
def in_process(frame: dict[str, Path], tmp_path_factory: pytest.TempPathFactory) -> dict[str, bytes]:
    out = tmp_path_factory.mktemp("inline") / "world"
    build(BuildRequest(output=out, **frame))
    return world_bytes(out)


def test_the_frame_estimates_height_and_pitch(in_process: dict[str, bytes]) -> None:
    """The frame exercises the long posterior sum (both camera parameters free)."""
    estimated = json.loads(in_process["report.json"])["camera"]["estimated"]
    assert {"height_m", "pitch"} <= set(estimated)


def test_report_writes_no_negative_zero(in_process: dict[str, bytes]) -> None:
    """Homography entries that are zero up to 1e-18 noise are written 0.0, not a noise-signed -0.0."""
    assert b"-0.0," not in in_process["report.json"] and b"-0.0\n" not in in_process["report.json"]


@pytest.mark.parametrize("threads", ["1", "2"])
def test_blas_and_openmp_threads_do_not_change_the_bytes(
    threads: str, frame: dict[str, Path], in_process: dict[str, bytes], tmp_path: Path
) -> None:
    outputs = {
        str(tmp_path / "omp"): {"OMP_NUM_THREADS": threads},
        str(tmp_path / "openblas"): {"OPENBLAS_NUM_THREADS": threads},
    }
    build_in_subprocesses(frame, outputs)
    for output in outputs:
        assert world_bytes(Path(output)) == in_process, output


def _manifest(frame: dict[str, Path], folder: Path) -> Path:
    """Two rows naming the frame: one frame for each of two workers."""
    rows = [{"id": name, **{k: str(v) for k, v in frame.items()}} for name in ("a", "b")]
    path = folder / "manifest.json"
    path.write_text(json.dumps(rows))
    return path


@pytest.mark.dask
def test_pool_and_dask_batches_give_the_bytes_of_an_in_process_build(
    frame: dict[str, Path], in_process: dict[str, bytes], tmp_path: Path
) -> None:
    manifest = _manifest(frame, tmp_path)
    pool, dask = tmp_path / "pool", tmp_path / "dask"
    assert main(["-q", "batch", str(manifest), "-o", str(pool), "--workers", "2"]) == 0
    assert main(["-q", "batch", str(manifest), "-o", str(dask), "--dask-local", "2"]) == 0
    assert output_bytes(dask) == output_bytes(pool)  # every layer, asset, report.json and index.usda
    assert stable_records(dask) == stable_records(pool)
    for frame_id in ("a", "b"):
        assert world_bytes(pool / frame_id) == in_process


@pytest.mark.shared_data
def test_a_real_kitti_frame_is_the_same_with_one_and_two_blas_threads(
    shared_data: Path, tmp_path: Path
) -> None:
    """KITTI 000001 (the frame of issue 17): in-process and with 1 and 2 BLAS/OpenMP threads."""
    root = shared_data / "kitti" / "training"
    frame = {
        "image": root / "image_2" / "000001.png",
        "detections": root / "label_2" / "000001.txt",
        "camera": root / "calib" / "000001.txt",
    }
    build(BuildRequest(output=tmp_path / "inline", **frame))
    outputs = {str(tmp_path / f"t{n}"): {"OMP_NUM_THREADS": n, "OPENBLAS_NUM_THREADS": n} for n in ("1", "2")}
    build_in_subprocesses(frame, outputs)
    expected = world_bytes(tmp_path / "inline")
    for output in outputs:
        assert world_bytes(Path(output)) == expected, output
