"""The small fixed scene behind the golden ``.usda`` files (shared by the test and its regeneration tool)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import cv2
import numpy as np

from usdworld.pipeline import BuildRequest, build

GOLDEN_DIR = Path(__file__).resolve().parent / "golden"
GOLDEN_FILES = ("world.usda", "layers/base.usda", "layers/edits.usda")

DETECTIONS = """\
Car 0.00 0 0.0 250.0 170.0 390.0 242.0 0 0 0 0 0 0 0
Pedestrian 0.00 0 0.0 470.0 150.0 492.0 212.0 0 0 0 0 0 0 0
Car 0.00 0 0.0 100.0 168.0 170.0 200.0 0 0 0 0 0 0 0
DontCare -1 -1 -10 10.0 10.0 20.0 20.0 -1 -1 -1 -1000 -1000 -1000 -10
"""


def write_inputs(folder: Path) -> BuildRequest:
    """Write the scene's input files into ``folder`` and return its build request."""
    folder.mkdir(parents=True, exist_ok=True)
    image = np.full((360, 640, 3), 96, dtype=np.uint8)
    image[180:] = 60
    cv2.imwrite(str(folder / "frame.png"), image)
    (folder / "frame.txt").write_text(DETECTIONS)
    camera = {"K": [[500.0, 0.0, 320.0], [0.0, 500.0, 170.0], [0.0, 0.0, 1.0]], "height_m": 1.6, "pitch_deg": 1.0, "roll_deg": 0.0}
    (folder / "camera.json").write_text(json.dumps(camera))
    return BuildRequest(
        image=folder / "frame.png",
        detections=folder / "frame.txt",
        camera=folder / "camera.json",
        output=folder / "world",
        infer_streets=False,  # the golden files pin the authoring of these boxes, not the street inference
    )


_NUMBER = re.compile(r"(?<![#\w])-?\d+\.\d+(?:e[-+]?\d+)?")
_SHA256 = re.compile(r"\b[0-9a-f]{64}\b")


def normalise(text: str) -> str:
    """Round decimals to 4 places and mask file hashes (the PNG encoder's bytes may vary)."""
    text = _SHA256.sub("<sha256>", text)

    def fix(match: re.Match[str]) -> str:
        value = round(float(match.group(0)), 4)
        return f"{value:.4f}".rstrip("0").rstrip(".") if value != 0 else "0"

    header, _, body = text.partition("\n")
    return header + "\n" + _NUMBER.sub(fix, body)


def build_golden(folder: Path) -> dict[str, str]:
    """Build the scene in ``folder`` and return the normalised text of each golden file."""
    result = build(write_inputs(folder))
    root = result.world.parent
    return {name: normalise((root / name).read_text()) for name in GOLDEN_FILES}
