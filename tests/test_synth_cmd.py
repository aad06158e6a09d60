"""``usdworld synth``: Cityscapes-format files that ``usdworld build`` accepts; one-line errors."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import pytest

from usdworld.cli.main import main

SUFFIXES = ("_leftImg8bit.png", "_gtFine_labelIds.png", "_gtFine_instanceIds.png", "_camera.json", "_gt.json")


def _run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_synth_files_are_cityscapes_and_build_accepts_them(tmp_path: Path, capsys) -> None:
    out = tmp_path / "synth"
    code, stdout, err = _run(
        capsys, "synth", "-o", str(out), "--seed", "5", "--count", "2", "--size", "256x128"
    )
    assert code == 0, err
    names = ["synth_000000_000005", "synth_000000_000006"]
    assert sorted(p.name for p in out.iterdir()) == sorted(n + s for n in names for s in SUFFIXES)
    assert (
        stdout.splitlines()[-1]
        == f"wrote 2 scene(s) of 256x128 to {out} (image, labelIds, instanceIds, camera, gt)"
    )
    stem = out / names[1]
    assert cv2.imread(f"{stem}_leftImg8bit.png").shape == (128, 256, 3)
    assert cv2.imread(f"{stem}_gtFine_labelIds.png", cv2.IMREAD_UNCHANGED).dtype.name == "uint8"
    assert cv2.imread(f"{stem}_gtFine_instanceIds.png", cv2.IMREAD_UNCHANGED).dtype.name == "uint16"
    assert set(json.loads(Path(f"{stem}_camera.json").read_text())) == {"extrinsic", "intrinsic"}
    world = tmp_path / "world"
    code, stdout, err = _run(
        capsys,
        "build",
        f"{stem}_leftImg8bit.png",
        "--labels",
        f"{stem}_gtFine_labelIds.png",
        "--instances",
        f"{stem}_gtFine_instanceIds.png",
        "--camera",
        f"{stem}_camera.json",
        "-o",
        str(world),
    )
    assert code == 0, err
    assert (
        world / "world.usda"
    ).is_file() and "objects placed from synth_000000_000006_leftImg8bit.png" in stdout


def test_scene_depends_on_its_seed_not_on_count(tmp_path: Path, capsys) -> None:
    a, b = tmp_path / "a", tmp_path / "b"
    assert _run(capsys, "synth", "-o", str(a), "--seed", "5", "--count", "2", "--size", "128x64")[0] == 0
    assert _run(capsys, "synth", "-o", str(b), "--seed", "6", "--size", "128x64")[0] == 0
    for suffix in SUFFIXES:
        name = f"synth_000000_000006{suffix}"
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["--seed", "-1"], "error: --seed must be >= 0, got -1"),
        (["--seed", "1", "--count", "0"], "error: --count must be >= 1, got 0"),
        (
            ["--seed", "1", "--size", "wide"],
            "error: --size 'wide': expected WIDTHxHEIGHT in pixels, e.g. 1024x512",
        ),
    ],
)
def test_synth_bad_input(tmp_path: Path, capsys, args, expected) -> None:
    code, _, err = _run(capsys, "synth", "-o", str(tmp_path / "s"), *args)
    assert code == 2 and err.strip() == expected, err
    assert not (tmp_path / "s").exists()


def test_synth_output_must_be_a_folder(tmp_path: Path, capsys) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")
    code, _, err = _run(capsys, "synth", "-o", str(blocker), "--seed", "1")
    assert code == 2 and err.strip() == f"error: -o {blocker}: exists and is not a folder"
    code, _, err = _run(capsys, "synth", "--seed", "1")
    assert code == 2 and "--output" in err
