"""Read a views manifest (``usdworld build --views VIEWS.json``).

Format (paths relative to the manifest's folder)::

    {
      "views": [
        {
          "name": "front",                          # optional, default view<i>; a USD prim name
          "image": "front.jpg",                     # required
          "K": [[fx, 0, cx], [0, fy, cy], [0, 0, 1]],   # or "camera": any camera file the
                                                    #   single-image build takes (its K is used)
          "camera_to_world": [[...4x4...]],         # OpenCV camera (x right, y down, z forward)
                                                    #   -> world (Z up, ground z = 0), metres;
                                                    #   or "ego_to_world" and "camera_to_ego"
          "timestamp": 0.0,                         # optional, seconds
          "labels": "...", "instances": "...",      # optional evidence, as the single-image
          "polygons": "...", "detections": "..."    #   build takes it
        }
      ]
    }

The pose fixes each camera's height, pitch and roll above the ground and its place in the
world, so a camera file's own extrinsics are not used. Unknown keys are errors (a typo would
otherwise silently drop evidence).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from usdworld.errors import InputError
from usdworld.io.camera_infos import is_info_document, is_pickle, parse_info_json
from usdworld.io.hashing import PathLike, as_array, as_float, as_floats, as_object, parse_json, read_input
from usdworld.views.types import ViewSet, ViewSpec, check_pose

#: Keys a view may have.
VIEW_KEYS = (
    "name",
    "image",
    "K",
    "camera",
    "camera_to_world",
    "ego_to_world",
    "camera_to_ego",
    "timestamp",
    "labels",
    "instances",
    "polygons",
    "detections",
)
_PATH_KEYS = ("image", "camera", "labels", "instances", "polygons", "detections")
_PRIM_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


def check_view_name(name: str, where: str) -> str:
    """A view name usable as a USD prim name, or an InputError naming ``where``."""
    if not _PRIM_NAME.match(name):
        raise InputError(
            f"{where}: view name {name!r} is not a valid USD prim name (letters, digits, '_'; not starting with a digit)"
        )
    return name


def _matrix(value: Any, where: str, rows: int) -> np.ndarray:
    entries = as_array(value, where)
    if len(entries) != rows:
        raise InputError(f"{where}: must be {rows} rows of {rows} numbers, got {len(entries)} rows")
    return np.array([as_floats(r, f"{where} -> [{i}]", rows) for i, r in enumerate(entries)])


def _pose(entry: dict[str, Any], where: str) -> np.ndarray:
    has_world = "camera_to_world" in entry
    has_ego = "ego_to_world" in entry or "camera_to_ego" in entry
    if has_world == has_ego:
        raise InputError(
            f"{where}: give the pose as camera_to_world, or as ego_to_world and camera_to_ego (one of the two)"
        )
    if has_world:
        return check_pose(
            _matrix(entry["camera_to_world"], f"{where} -> camera_to_world", 4), f"{where} -> camera_to_world"
        )
    for key in ("ego_to_world", "camera_to_ego"):
        if key not in entry:
            raise InputError(f"{where}: {key} is missing (camera_to_ego needs ego_to_world, and back)")
    world_from_ego = _matrix(entry["ego_to_world"], f"{where} -> ego_to_world", 4)
    ego_from_cam = _matrix(entry["camera_to_ego"], f"{where} -> camera_to_ego", 4)
    return check_pose(world_from_ego @ ego_from_cam, f"{where} -> ego_to_world @ camera_to_ego")


def _path(folder: Path, value: Any, where: str) -> Path:
    if not isinstance(value, str) or not value:
        raise InputError(f"{where}: must be a non-empty path string")
    p = Path(value)
    return p if p.is_absolute() else folder / p


def _view(entry_value: Any, index: int, folder: Path, where: str) -> ViewSpec:
    entry = as_object(entry_value, where)
    unknown = sorted(set(entry) - set(VIEW_KEYS))
    if unknown:
        raise InputError(f"{where} -> {unknown[0]}: unknown key; the keys are {', '.join(VIEW_KEYS)}")
    if "image" not in entry:
        raise InputError(f"{where}: image is missing")
    if ("K" in entry) == ("camera" in entry):
        raise InputError(f"{where}: give the intrinsics as K or as a camera file (one of the two)")
    name = entry.get("name", f"view{index}")
    if not isinstance(name, str):
        raise InputError(f"{where} -> name: must be a string")
    check_view_name(name, f"{where} -> name")
    paths = {k: _path(folder, entry[k], f"{where} -> {k}") for k in _PATH_KEYS if k in entry}
    K = None
    if "K" in entry:
        K = _matrix(entry["K"], f"{where} -> K", 3)
        if not (K[1, 0] == 0 and np.allclose(K[2], [0.0, 0.0, 1.0]) and K[0, 0] > 0 and K[1, 1] > 0):
            raise InputError(
                f"{where} -> K: must be [[fx, s, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0, got {K.tolist()}"
            )
    timestamp = as_float(entry["timestamp"], f"{where} -> timestamp") if "timestamp" in entry else None
    if "instances" in paths and "labels" not in paths:
        raise InputError(f"{where}: instances needs labels (the labelIds PNG of the same photo)")
    if "polygons" in paths and "labels" in paths:
        raise InputError(f"{where}: give either polygons or labels/instances, not both")
    return ViewSpec(
        name=name,
        image=paths["image"],
        world_from_cam=_pose(entry, where),
        K=K,
        camera=paths.get("camera"),
        timestamp=timestamp,
        labels=paths.get("labels"),
        instances=paths.get("instances"),
        polygons=paths.get("polygons"),
        detections=paths.get("detections"),
    )


def _lenient_json(data: bytes) -> Any:
    """The document when ``data`` parses as JSON with NaN allowed (as info files hold), else None."""
    try:
        return parse_info_json(data, "")
    except InputError:
        return None


def read_views_manifest(path: PathLike) -> ViewSet:
    """Read a views manifest (format in the module docstring).

    Args:
        path: the manifest JSON.

    Returns:
        The views in file order; the world frame is the manifest's.

    Raises:
        InputError: malformed JSON, a missing, unknown or mistyped key (named by its path),
            a pose that is not rigid or puts the camera below the ground, or two views of one name.
    """
    data, file = read_input(path, "views")
    if is_pickle(data) or is_info_document(_lenient_json(data)):
        raise InputError(
            f"{file.name}: an mmdetection3d info file, not a views manifest; pass --layout nuscenes"
        )
    doc = as_object(parse_json(data, file.name), file.name)
    unknown = sorted(set(doc) - {"views"})
    if unknown:
        raise InputError(f"{file.name} -> {unknown[0]}: unknown key; a views manifest holds 'views'")
    if "views" not in doc:
        raise InputError(f'{file.name}: views is missing; the manifest is {{"views": [{{...}}, ...]}}')
    entries = as_array(doc["views"], f"{file.name} -> views")
    if not entries:
        raise InputError(f"{file.name} -> views: is empty; list at least one view")
    folder = Path(path).parent
    views = tuple(_view(v, i, folder, f"{file.name} -> views -> [{i}]") for i, v in enumerate(entries))
    seen: dict[str, int] = {}
    for i, view in enumerate(views):
        if view.name in seen:
            raise InputError(
                f"{file.name} -> views -> [{i}] -> name: {view.name!r} is also view [{seen[view.name]}]'s name"
            )
        seen[view.name] = i
    return ViewSet(views=views, source=file, frame="manifest world")
