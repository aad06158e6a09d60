"""A small synthetic world for the editing tests (imported by the other test_edit* modules).

The world is built by ``usdworld.pipeline.build`` from label images drawn with numpy: a
straight road (|y| < 5 m) between two sidewalks, two cars on the road and a person on
the right sidewalk, seen by a level camera 1.5 m above the ground. It is built once per
test session and copied for each test.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import cv2
import numpy as np
from pxr import Sdf

W, H, F, CAM_H = 512, 256, 300.0, 1.5
ROAD_HALF_WIDTH_M = 5.0
_TEMPLATE: dict[str, Path] = {}


def _v(depth: float) -> float:
    return H / 2 + F * CAM_H / depth


def _u(depth: float, y: float) -> float:
    return W / 2 - F * y / depth


def write_frame(out: Path) -> dict[str, Path]:
    """Label, instance and camera files of the synthetic street."""
    out.mkdir(parents=True, exist_ok=True)
    labels = np.full((H, W), 23, np.uint8)  # sky
    for v in range(H // 2 + 2, H):
        d = F * CAM_H / (v - H / 2)
        labels[v, :] = 8  # sidewalk
        u_l, u_r = (round(_u(d, y)) for y in (ROAD_HALF_WIDTH_M, -ROAD_HALF_WIDTH_M))
        labels[v, max(u_l, 0) : max(min(u_r, W), 0)] = 7  # road
    inst = labels.astype(np.uint16)

    def obj(cls_id: int, k: int, depth: float, y: float, w_m: float, h_m: float) -> None:
        vb = round(_v(depth))
        vt = round(vb - F * h_m / depth)
        uc, hw = _u(depth, y), F * w_m / depth / 2
        labels[vt:vb, round(uc - hw) : round(uc + hw)] = cls_id
        inst[vt:vb, round(uc - hw) : round(uc + hw)] = cls_id * 1000 + k

    obj(26, 1, 20.0, 1.5, 1.8, 1.5)  # car_0001
    obj(26, 2, 14.0, -2.5, 1.8, 1.5)  # car_0002
    obj(24, 1, 12.0, -6.5, 0.6, 1.75)  # person_0001
    files = {
        "image": out / "street_leftImg8bit.png",
        "labels": out / "street_gtFine_labelIds.png",
        "instances": out / "street_gtFine_instanceIds.png",
        "camera": out / "street_camera.json",
    }
    cv2.imwrite(str(files["image"]), np.dstack([labels * 5, labels * 3, labels * 7]))
    cv2.imwrite(str(files["labels"]), labels)
    cv2.imwrite(str(files["instances"]), inst)
    cam = {
        "fx": F,
        "fy": F,
        "cx": W / 2,
        "cy": H / 2,
        "height_m": CAM_H,
        "pitch_deg": 0.0,
        "roll_deg": 0.0,
        "yaw_deg": 0.0,
    }
    files["camera"].write_text(json.dumps(cam))
    return files


def build_world(frame: dict[str, Path], out: Path) -> Path:
    """Build (or rebuild) the world folder; returns its root layer."""
    from usdworld.pipeline import BuildRequest, build

    result = build(BuildRequest(output=out, **frame))
    return result.world


def template(tmp_path_factory) -> tuple[dict[str, Path], Path]:
    """The session's frame files and pristine world folder (built on first use)."""
    if "world" not in _TEMPLATE:
        tmp_root = tmp_path_factory.mktemp("edit_template")
        frame = write_frame(tmp_root / "frame")
        _TEMPLATE["world"] = build_world(frame, tmp_root / "template").parent
        _TEMPLATE.update({f"frame:{k}": v for k, v in frame.items()})
    frame = {k.split(":", 1)[1]: v for k, v in _TEMPLATE.items() if k.startswith("frame:")}
    return frame, _TEMPLATE["world"]


def fresh_world(tmp_path_factory, dest: Path) -> Path:
    """A private copy of the template world at ``dest``; returns its ``world.usda``."""
    _, world = template(tmp_path_factory)
    shutil.copytree(world, dest)
    return dest / "world.usda"


def sha256(path: Path) -> str:
    """Hex digest of a file."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def test_template_world_has_the_drawn_objects(tmp_path_factory):
    from usdworld.authoring.edits import WorldEditor

    root = fresh_world(tmp_path_factory, tmp_path_factory.mktemp("w") / "world")
    with WorldEditor(root) as editor:
        objects = {o.name: o for o in editor.objects()}
        assert sorted(objects) == ["car_0001", "car_0002", "person_0001"]
        assert objects["car_0001"].position_world[0] > 20 and objects["car_0002"].position_world[1] < 0
        ground = editor.ground()
        assert set(ground.triangles) == {"road", "sidewalk"}


def base_x(world: Path, name: str) -> float:
    """World x of an object as the base layer places it (before any edit)."""
    layer = Sdf.Layer.FindOrOpen(str(world.parent / "layers/base.usda"))
    spec = layer.GetAttributeAtPath(f"/World/Objects/{name}.xformOp:translate")
    return float(spec.default[0])
