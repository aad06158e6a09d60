"""``--segment`` and ``usdworld segment``: option checks, each a one-line error with exit 2
(no network and no torch needed: they fail before a model loads)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from usdworld.cli.main import main


@pytest.fixture
def photo(tmp_path):
    image = tmp_path / "street.png"
    cv2.imwrite(str(image), np.full((40, 60, 3), 100, np.uint8))
    labels = tmp_path / "street_labelIds.png"
    cv2.imwrite(str(labels), np.full((40, 60), 7, np.uint8))
    not_model = tmp_path / "not_a_model"
    not_model.mkdir()
    return {"image": image, "labels": labels, "not_model": not_model, "dir": tmp_path}


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--segment", "hf"], "--segment hf: needs --segment-model DIR, a segmentation model folder written elsewhere"),
        (["--segment-model", "{not_model}"], "--segment-model needs --segment hf"),
        (["--segment", "hf", "--segment-model", "{not_model}", "--labels", "{labels}"], "pass either --segment"),
        (["--segment", "hf", "--segment-model", "{not_model}"], "not_a_model: not a model folder (no config.json)"),
        (["--segment", "hf", "--segment-model", "{dir}/nowhere"], "nowhere: not a model folder"),
        (["--views", "{dir}/views.json", "--segment", "hf"], "--segment: a views build takes each view's labels"),
    ],
)
def test_build_segment_option_errors_are_one_line(photo, capsys, args, message) -> None:
    filled = [a.format(**photo) for a in args]
    image = [] if "--views" in args else [str(photo["image"])]
    code = main(["build", *image, *filled, "-o", str(photo["dir"] / "w")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and err.startswith("error: ") and message in err, err
    assert not (photo["dir"] / "w").exists()


def test_segment_command_needs_a_model_folder(photo, capsys) -> None:
    code = main(["segment", str(photo["image"]), "--segment-model", str(photo["not_model"]), "-o", str(photo["dir"] / "s")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "not_a_model: not a model folder (no config.json)" in err
    assert not (photo["dir"] / "s").exists()
