"""``usdworld render``: every output file, its format, and one-line errors for bad input.

Needs headless OpenGL; without it the command exits 1 with the RenderError message naming
the packages to install, and these tests fail (they never skip).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from usdworld.cli.main import main
from usdworld.pipeline import BuildRequest, build
from usdworld.render.outputs import (
    SKY_ID,
    colorize_depth,
    colorize_labels,
    overlay,
    png_bytes,
    side_by_side,
)
from usdworld.synth import make_street_scene, write_cityscapes_frame

W, H = 256, 128
#: What ``usdworld render`` writes by default (``--write data``).
DATA_FILES = {"render.png", "labelIds.png", "instanceIds.png", "depth.npy"}
#: ``--write all`` without a photo.
ALL_FILES = DATA_FILES | {"class.png", "instance.png", "depth.png"}


def _run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def world(tmp_path_factory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("rendercmd")
    scene = make_street_scene(np.random.default_rng(7), W, H)
    files = write_cityscapes_frame(scene, root / "frames", "synth_000000_000007")
    result = build(
        BuildRequest(
            image=files["image"],
            labels=files["labels"],
            instances=files["instances"],
            camera=files["camera"],
            output=root / "w",
        )
    )
    return {**files, "world": result.world}


def test_quiet_render_prints_no_file_list(world, tmp_path, capsys) -> None:
    """`usdworld -q render` writes its files and prints nothing but warnings and errors."""
    out = tmp_path / "out"
    code, stdout, err = _run(capsys, "-q", "render", str(world["world"]), "-o", str(out))
    assert code == 0 and stdout == "", (stdout, err)
    assert (out / "render.png").is_file()


def test_render_writes_every_file(world, tmp_path, capsys) -> None:
    out = tmp_path / "out"
    code, stdout, err = _run(
        capsys,
        "render",
        str(world["world"]),
        "-o",
        str(out),
        "--photo",
        str(world["image"]),
        "--write",
        "all",
    )
    assert code == 0, err
    assert {p.name for p in out.iterdir()} == ALL_FILES | {"side_by_side.png", "overlay.png"}
    assert stdout.splitlines()[-1].startswith(f"rendered {W}x{H} from /World/SourceCamera: ")
    rgb = cv2.imread(str(out / "render.png"), cv2.IMREAD_UNCHANGED)
    labels = cv2.imread(str(out / "labelIds.png"), cv2.IMREAD_UNCHANGED)
    inst = cv2.imread(str(out / "instanceIds.png"), cv2.IMREAD_UNCHANGED)
    depth = np.load(out / "depth.npy")
    assert rgb.shape == (H, W, 3) and labels.shape == (H, W) and labels.dtype == np.uint8
    assert inst.dtype == np.uint16 and inst.shape == (H, W)
    assert depth.dtype == np.float32 and depth.shape == (H, W)
    assert np.all((depth > 0) | (labels == SKY_ID))  # sky exactly where nothing was hit
    assert np.all(inst[inst >= 1000] // 1000 == labels[inst >= 1000])
    assert {7, 26} <= set(np.unique(labels).tolist())  # road and cars
    cls = cv2.imread(str(out / "class.png"))[:, :, ::-1]
    assert np.array_equal(cls, colorize_labels(labels))
    assert cv2.imread(str(out / "side_by_side.png")).shape == (H, 2 * W + 4, 3)
    assert cv2.imread(str(out / "overlay.png")).shape == (H, W, 3)


def test_render_finds_the_photo_next_to_the_world_and_takes_size_and_camera(world, tmp_path, capsys) -> None:
    copy = tmp_path / "w"
    shutil.copytree(world["world"].parent, copy)
    out = tmp_path / "plain"
    code, _, err = _run(
        capsys,
        "render",
        str(copy),
        "-o",
        str(out),
        "--size",
        "128x64",
        "--camera",
        "/World/SourceCamera",
        "--write",
        "all",
    )
    assert code == 0, err
    assert {p.name for p in out.iterdir()} == ALL_FILES  # no photo beside this copy
    code, _, err = _run(capsys, "render", str(copy), "-o", str(tmp_path / "cmp"), "--write", "side_by_side")
    assert code == 2 and err.strip() == (
        f"error: --write side_by_side: the source photo '{Path(world['image']).name}' is not next to the world; "
        "pass it with --photo"
    ), err
    assert np.load(out / "depth.npy").shape == (64, 128)
    shutil.copy(
        world["image"], tmp_path / Path(world["image"]).name
    )  # now the photo sits beside the world folder
    code, _, err = _run(
        capsys,
        "render",
        str(copy / "world.usda"),
        "-o",
        str(tmp_path / "withphoto"),
        "--write",
        "comparisons",
    )
    assert code == 0, err
    assert {p.name for p in (tmp_path / "withphoto").iterdir()} == {"side_by_side.png", "overlay.png"}


def test_render_writes_the_data_only_by_default(world, tmp_path, capsys) -> None:
    """Without --write: the passes as data, no views, no comparisons (even with --photo)."""
    out = tmp_path / "out"
    code, stdout, err = _run(
        capsys, "render", str(world["world"]), "-o", str(out), "--photo", str(world["image"])
    )
    assert code == 0, err
    assert {p.name for p in out.iterdir()} == DATA_FILES
    assert [Path(line).name for line in stdout.splitlines()[:-1]] == [
        "render.png",
        "labelIds.png",
        "instanceIds.png",
        "depth.npy",
    ]
    code, _, err = _run(
        capsys, "render", str(world["world"]), "-o", str(tmp_path / "two"), "--write", "depth,class"
    )
    assert code == 0, err
    assert {p.name for p in (tmp_path / "two").iterdir()} == {"depth.npy", "class.png"}


def test_png_settings_are_lossless() -> None:
    """The fast PNG settings change the bytes, never the pixels (colour, 8-bit and 16-bit grey)."""
    rng = np.random.default_rng(3)
    rgb = rng.integers(0, 256, (37, 53, 3), dtype=np.uint8)
    rgb[:, :20] = (10, 20, 30)  # flat runs, as renders have, and noise
    ids = rng.integers(0, 65536, (37, 53), dtype=np.uint16)
    for image in (rgb, ids, ids.astype(np.uint8)):
        decoded = cv2.imdecode(np.frombuffer(png_bytes(image), np.uint8), cv2.IMREAD_UNCHANGED)
        expected = image[:, :, ::-1] if image.ndim == 3 else image  # OpenCV decodes to BGR
        assert decoded.dtype == image.dtype and np.array_equal(decoded, expected)


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["--size", "10x"], "error: --size '10x': expected WIDTHxHEIGHT in pixels, e.g. 1024x512"),
        (["--size", "0x10"], "error: --size '0x10': width and height must be 1..8192 pixels"),
        (
            ["--camera", "/World/Nope"],
            "error: --camera /World/Nope: no such prim; cameras in the stage: /World/SourceCamera",
        ),
        (["--camera", "/World/Objects"], "error: --camera /World/Objects: is a Scope prim, not a Camera"),
        (
            ["--photo", "/nonexistent/p.png"],
            "error: /nonexistent/p.png: no such photo; pass --photo with the source image",
        ),
        (
            ["--write", "data,shadows"],
            (
                "error: --write 'data,shadows': unknown output 'shadows'; choose from data, views, comparisons, "
                "all, render, labelIds, instanceIds, depth, class, instance, depth_png, side_by_side, overlay"
            ),
        ),
        (["--write", ","], "error: --write ',': names no output; e.g. --write data or --write all"),
        (
            ["--time", "1"],
            "error: --time 1: the world has no time range (only a drive's world, build --views of "
            "timestamped views, has one); drop --time",
        ),
    ],
)
def test_render_bad_input_is_one_line_exit_2(world, tmp_path, capsys, args, expected) -> None:
    code, _, err = _run(capsys, "render", str(world["world"]), "-o", str(tmp_path / "o"), *args)
    assert code == 2 and err.strip() == expected, err
    assert not (tmp_path / "o").exists()


def test_render_missing_world_and_file_as_output(world, tmp_path, capsys) -> None:
    code, _, err = _run(capsys, "render", str(tmp_path / "nope"), "-o", str(tmp_path / "o"))
    assert (
        code == 2
        and err.strip()
        == f"error: {tmp_path / 'nope'}: no such file; pass a world's world.usda (or its folder)"
    )
    blocker = tmp_path / "file"
    blocker.write_text("x")
    code, _, err = _run(capsys, "render", str(world["world"]), "-o", str(blocker))
    assert code == 2 and err.strip() == f"error: {blocker}: exists and is not a folder; choose another -o"


def test_image_helpers_known_answers() -> None:
    assert colorize_labels(np.array([[26, 7, 23]])).tolist() == [
        [[0, 0, 142], [128, 64, 128], [70, 130, 180]]
    ]
    depth = np.array([[0.0, 1.0, 100.0]])
    d = colorize_depth(depth)
    assert d[0, 0].tolist() == [0, 0, 0] and d[0, 1].tolist() != d[0, 2].tolist()
    photo = np.full((20, 40, 3), 200, np.uint8)
    render = np.zeros((10, 20, 3), np.uint8)
    sbs = side_by_side(photo, render)
    assert (
        sbs.shape == (10, 44, 3)
        and sbs[0, 0].tolist() == [200, 200, 200]
        and sbs[0, 43].tolist() == [0, 0, 0]
    )
    assert overlay(photo, render, 0.5)[0, 0].tolist() == [100, 100, 100]


def test_missing_gl_is_a_one_line_error_with_the_install_hint(world, tmp_path, capsys, monkeypatch) -> None:
    import moderngl

    from usdworld.render import INSTALL_HINT

    def broken(*args: object, **kwargs: object) -> None:
        raise Exception("eglGetDisplay failed")  # noqa: TRY002  (what glcontext raises)

    monkeypatch.setattr(moderngl, "create_standalone_context", broken)
    code, _, err = _run(capsys, "-q", "render", str(world["world"]), "-o", str(tmp_path / "o"))
    lines = err.strip().splitlines()
    assert code == 1 and len(lines) == 1 and lines[0].startswith("error: headless OpenGL"), err
    assert INSTALL_HINT in lines[0]
