"""A small demo-like street drawn with numpy, built into a world: the input of the export tests.

The label and instance images are drawn directly (Cityscapes ids): sky, a building on the
left, sidewalks, the road, three cars on the road and a person on the right sidewalk. The
other export test modules import :func:`build_street_world` from here.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import cv2
import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom

from usdworld.pipeline import BuildRequest, build

ROAD, SIDEWALK, BUILDING, SKY, PERSON, CAR = 7, 8, 11, 23, 24, 26
WIDTH, HEIGHT = 640, 320
FX = 400.0
CAMERA_HEIGHT_M = 1.5


def _ground_row(distance_m: float) -> int:
    """Image row of the ground at a distance (pitch 0, principal point at the centre)."""
    return round(HEIGHT / 2 + FX * CAMERA_HEIGHT_M / distance_m)


def _column(lateral_m: float, distance_m: float) -> int:
    """Image column of a point ``lateral_m`` to the right at a distance."""
    return round(WIDTH / 2 + FX * lateral_m / distance_m)


def write_street(folder: Path) -> dict[str, Path]:
    """Write image, labelIds, instanceIds and camera JSON of the street; returns BuildRequest paths."""
    folder.mkdir(parents=True, exist_ok=True)
    labels = np.full((HEIGHT, WIDTH), SKY, dtype=np.uint8)
    instances = np.zeros((HEIGHT, WIDTH), dtype=np.uint16)
    horizon = HEIGHT // 2
    rows = np.arange(HEIGHT)[:, None]
    cols = np.arange(WIDTH)[None, :]
    below = rows > horizon
    # ground: lateral offset of each pixel on the ground plane, from its row and column
    distance = FX * CAMERA_HEIGHT_M / np.maximum(rows - HEIGHT / 2, 1e-6)
    lateral = np.where(below, (cols - WIDTH / 2) * distance / FX, 0.0)
    labels[below & (np.abs(lateral) <= 4.0)] = ROAD
    labels[below & (np.abs(lateral) > 4.0)] = SIDEWALK
    labels[: horizon + 2, : WIDTH // 5] = BUILDING
    cars = [(-1.8, 12.0), (1.9, 18.0), (-2.0, 25.0)]
    for k, (lat, dist) in sorted(enumerate(cars), key=lambda c: -c[1][1]):
        bottom, top = _ground_row(dist), _ground_row(dist) - int(FX * 1.5 / dist)
        left, right = _column(lat - 0.9, dist), _column(lat + 0.9, dist)
        labels[top:bottom, left:right] = CAR
        instances[top:bottom, left:right] = CAR * 1000 + k
    dist, lat = 10.0, 5.5
    bottom, top = _ground_row(dist), _ground_row(dist) - int(FX * 1.75 / dist)
    left, right = _column(lat - 0.25, dist), _column(lat + 0.25, dist)
    labels[top:bottom, left:right] = PERSON
    instances[top:bottom, left:right] = PERSON * 1000
    # stuff pixels carry their label id as instance id, as in Cityscapes
    stuff = instances == 0
    instances[stuff] = labels[stuff]
    palette = {ROAD: (128, 64, 128), SIDEWALK: (232, 35, 244), BUILDING: (70, 70, 70), SKY: (180, 130, 70),
               PERSON: (60, 20, 220), CAR: (142, 0, 0)}
    image = np.zeros((HEIGHT, WIDTH, 3), dtype=np.uint8)
    for label, bgr in palette.items():
        image[labels == label] = bgr
    paths = {
        "image": folder / "street_000000_000019_leftImg8bit.png",
        "labels": folder / "street_000000_000019_gtFine_labelIds.png",
        "instances": folder / "street_000000_000019_gtFine_instanceIds.png",
        "camera": folder / "street_000000_000019_camera.json",
    }
    cv2.imwrite(str(paths["image"]), image)
    cv2.imwrite(str(paths["labels"]), labels)
    cv2.imwrite(str(paths["instances"]), instances)
    camera = {
        "extrinsic": {"baseline": 0.0, "pitch": 0.0, "roll": 0.0, "yaw": 0.0, "x": 0.0, "y": 0.0, "z": CAMERA_HEIGHT_M},
        "intrinsic": {"fx": FX, "fy": FX, "u0": WIDTH / 2, "v0": HEIGHT / 2},
    }
    paths["camera"].write_text(json.dumps(camera, indent=2))
    return paths


def build_street_world(folder: Path, library: Path | None = None) -> Path:
    """Draw the street into ``folder/input`` and build it into ``folder/world``; returns world.usda."""
    inputs = write_street(folder / "input")
    result = build(BuildRequest(output=folder / "world", library=library, **inputs))
    return result.world


def add_edits(root: Path) -> dict[str, str]:
    """Author typical user edits in ``layers/edits.usda``: move a car, delete the person, swap a variant.

    Returns:
        What was edited: ``moved``, ``deleted``, ``swapped`` -> prim path.
    """
    stage = Usd.Stage.Open(str(root))
    edits = Sdf.Layer.FindOrOpen(str(root.parent / "layers" / "edits.usda"))
    objects = [p for p in stage.GetPrimAtPath("/World/Objects").GetChildren()]
    cars = [p for p in objects if p.GetName().startswith("car_")]
    person = next(p for p in objects if p.GetName().startswith("person_"))
    with Usd.EditContext(stage, edits):
        UsdGeom.Xformable(cars[0]).GetOrderedXformOps()[0].Set(Gf.Vec3d(9.5, -3.0, 0.0))
        person.SetActive(False)
        vset = cars[1].GetVariantSet("model")
        other = next(v for v in vset.GetVariantNames() if v != vset.GetVariantSelection())
        vset.SetVariantSelection(other)
    edits.Save()
    return {"moved": str(cars[0].GetPath()), "deleted": str(person.GetPath()), "swapped": str(cars[1].GetPath()), "variant": other}


def test_street_world_has_cars_a_person_and_ground(tmp_path: Path) -> None:
    root = build_street_world(tmp_path)
    stage = Usd.Stage.Open(str(root))
    names = [p.GetName() for p in stage.GetPrimAtPath("/World/Objects").GetChildren()]
    assert sum(n.startswith("car_") for n in names) == 3, names
    assert sum(n.startswith("person_") for n in names) == 1, names
    assert stage.GetPrimAtPath("/World/Ground/Road").IsA(UsdGeom.Mesh)


# --------------------------------------------------------------------------------------------
# External tools (node, npm packages, chromium)
# --------------------------------------------------------------------------------------------

REPO = Path(__file__).resolve().parents[1]
WEB = REPO / "web"
WEB_HINT = "run tools/setup_web.sh (Debian chromium, node >= 20 and web/'s pinned npm packages)"


def missing_web_tools(npm_packages: tuple[str, ...], chromium: bool = False) -> list[str]:
    """What of node, web/node_modules/<package> and chromium is missing."""
    import shutil

    missing = [] if shutil.which("node") else ["node"]
    missing += [f"web/node_modules/{p}" for p in npm_packages if not (WEB / "node_modules" / p / "package.json").is_file()]
    if chromium:
        exe = os.environ.get("USDWORLD_CHROMIUM", "/usr/bin/chromium")
        if not Path(exe).is_file():
            missing.append(exe)
    return missing


def require_web_tools(npm_packages: tuple[str, ...], chromium: bool = False) -> None:
    """Fail (in CI, or with USDWORLD_REQUIRE_WEB=1) or skip (elsewhere) when web tools are missing."""
    import pytest

    missing = missing_web_tools(npm_packages, chromium)
    if not missing:
        return
    message = f"missing {', '.join(missing)}: {WEB_HINT}"
    if os.environ.get("CI") or os.environ.get("USDWORLD_REQUIRE_WEB") == "1":
        pytest.fail(message)
    pytest.skip(message)
