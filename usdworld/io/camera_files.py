"""Read camera calibration files into a :class:`CameraSpec`.

Four formats, recognised from the content:

* Cityscapes camera JSON::

    {"extrinsic": {"baseline": .., "pitch": .., "roll": .., "yaw": .., "x": .., "y": .., "z": ..},
     "intrinsic": {"fx": .., "fy": .., "u0": .., "v0": ..}}

  ``K`` from fx, fy, u0, v0; ``height_m`` = z; pitch, roll, yaw in radians as given
  (Cityscapes pitch is positive looking down, as in usdworld). All of these are required.
* KITTI object calib text (``P2: <12 numbers>``, or ``P_rect_02:`` of the raw data):
  ``K = P2[:, :3]``. ``P2 = K [I | t]`` also holds the offset ``t`` of camera 2 from the
  rectified camera-0 frame (``X_cam2 = X_cam0 + t``, about 6 cm); the spec describes
  camera 2 itself, so t only moves a KITTI ground plane to camera 2 (below). Use
  :func:`read_kitti_projection` and :func:`cam2_offset_from_projection` to compare with
  KITTI 3D labels, which are in the camera-0 frame.
* plain JSON, every key optional::

    {"K": [[fx, 0, cx], [0, fy, cy], [0, 0, 1]],   # or "fx", "fy", "cx", "cy"
     "height_m": 1.5, "pitch_deg": 2.0, "roll_deg": 0.0, "yaw_deg": 0.0}

* one camera of an mmdetection3d info JSON (nuScenes, KITTI ...), named after a ``#``:
  ``info.json#CAM_FRONT`` (:mod:`usdworld.io.camera_infos`): ``K`` from ``cam2img``; with
  ``cam2ego`` (nuScenes) also the height, pitch and roll above the ego frame's ground.

Files that are close but not enough get their own one-line message: an info file without
``#CAMERA`` (it lists the cameras), a pickled info file, a KITTI calib file without ``P2``.

A KITTI ground-plane file (``planes/*.txt``: a ``# Matrix`` / ``WIDTH 4`` / ``HEIGHT 1``
header, then ``a b c d`` with ``a x + b y + c z + d = 0`` in the rectified camera frame,
y down) gives the camera height ``|d| / ||(a, b, c)||`` and the pitch and roll from the
plane normal; it may only be combined with a camera file that gives no extrinsics.
"""

from __future__ import annotations

import logging
import math
import re
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from usdworld.errors import CalibrationError, InputError
from usdworld.io.camera_infos import (
    info_without_camera_message,
    is_info_document,
    is_pickle,
    parse_info_json,
    pickle_message,
    read_info_camera,
    split_camera_ref,
)
from usdworld.io.hashing import (
    PathLike,
    as_array,
    as_float,
    as_floats,
    as_object,
    decode_text,
    parse_json,
    read_input,
    require,
)
from usdworld.io.limits import (
    MAX_CAMERA_HEIGHT_M,
    MAX_FOCAL_PX,
    MAX_FOCAL_WIDTHS,
    MAX_PIXEL_COORD,
    MAX_PLANE_COEFF,
    MAX_YAW_DEG,
    check_range,
)
from usdworld.io.types import CameraSpec, InputFile, SourceImage

logger = logging.getLogger(__name__)

#: Largest accepted |pitch| and |roll|; a street camera beyond this is a sign or unit error.
MAX_TILT_DEG = 45.0

PLAIN_KEYS = ("K", "fx", "fy", "cx", "cy", "height_m", "pitch_deg", "roll_deg", "yaw_deg")
_KITTI_LINE = re.compile(r"^\s*([A-Za-z0-9_]+)\s*:(.*)$")


@dataclass
class _Parsed:
    """What one camera file gave, with the field path of each value for error messages."""

    source: str
    K: np.ndarray | None = None
    K_where: dict[str, str] = field(default_factory=dict)
    height_m: float | None = None
    pitch: float | None = None
    roll: float | None = None
    yaw: float | None = None
    where: dict[str, str] = field(default_factory=dict)
    cam_offset: np.ndarray | None = None  # KITTI t of P2 = K [I | t]


def _matrix_K(fx: float, fy: float, cx: float, cy: float, skew: float = 0.0) -> np.ndarray:
    return np.array([[fx, skew, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])


# --- formats --------------------------------------------------------------------------


def _parse_cityscapes(doc: dict[str, Any], name: str) -> _Parsed:
    out = _Parsed("cityscapes")
    intr = as_object(require(doc, "intrinsic", name), f"{name} -> intrinsic")
    extr = as_object(require(doc, "extrinsic", name), f"{name} -> extrinsic")
    w_in, w_ex = f"{name} -> intrinsic", f"{name} -> extrinsic"
    v = {k: as_float(require(intr, k, w_in), f"{w_in} -> {k}") for k in ("fx", "fy", "u0", "v0")}
    out.K = _matrix_K(v["fx"], v["fy"], v["u0"], v["v0"])
    out.K_where = {"fx": f"{w_in} -> fx", "fy": f"{w_in} -> fy", "cx": f"{w_in} -> u0", "cy": f"{w_in} -> v0"}
    e = {k: as_float(require(extr, k, w_ex), f"{w_ex} -> {k}") for k in ("pitch", "roll", "yaw", "z")}
    out.height_m, out.pitch, out.roll, out.yaw = e["z"], e["pitch"], e["roll"], e["yaw"]
    out.where = {k: f"{w_ex} -> {k}" for k in ("pitch", "roll", "yaw")} | {"height_m": f"{w_ex} -> z"}
    return out


def _parse_plain(doc: dict[str, Any], name: str) -> _Parsed:
    out = _Parsed("plain")
    unknown = sorted(set(doc) - set(PLAIN_KEYS))
    if unknown:
        raise InputError(f"{name} -> {unknown[0]}: unknown key; the keys are {', '.join(PLAIN_KEYS)}")
    separate = [k for k in ("fx", "fy", "cx", "cy") if k in doc]
    if "K" in doc and separate:
        raise InputError(f"{name}: gives both K and {separate[0]}; keep K or fx, fy, cx, cy")
    if "K" in doc:
        rows = as_array(doc["K"], f"{name} -> K")
        if len(rows) != 3:
            raise InputError(
                f"{name} -> K: must be 3 rows [[fx, 0, cx], [0, fy, cy], [0, 0, 1]], got {len(rows)}"
            )
        K = np.array([as_floats(r, f"{name} -> K -> [{i}]", 3) for i, r in enumerate(rows)])
        if not (K[1, 0] == 0 and np.allclose(K[2], [0.0, 0.0, 1.0])):
            raise InputError(
                f"{name} -> K: must be [[fx, s, cx], [0, fy, cy], [0, 0, 1]], got {K.tolist()}; "
                "divide by K[2][2] and check it is not transposed"
            )
        out.K = K
        out.K_where = {
            k: f"{name} -> K -> {ij}"
            for k, ij in (("fx", "[0][0]"), ("fy", "[1][1]"), ("cx", "[0][2]"), ("cy", "[1][2]"))
        }
    elif separate:
        v = {k: as_float(require(doc, k, name), f"{name} -> {k}") for k in ("fx", "fy", "cx", "cy")}
        out.K = _matrix_K(v["fx"], v["fy"], v["cx"], v["cy"])
        out.K_where = {k: f"{name} -> {k}" for k in v}
    if "height_m" in doc:
        out.height_m = as_float(doc["height_m"], f"{name} -> height_m")
    for key in ("pitch", "roll", "yaw"):
        if f"{key}_deg" in doc:
            setattr(out, key, math.radians(as_float(doc[f"{key}_deg"], f"{name} -> {key}_deg")))
    out.where = {k: f"{name} -> {k}_deg" for k in ("pitch", "roll", "yaw")} | {
        "height_m": f"{name} -> height_m"
    }
    return out


def _kitti_entries(text: str, name: str) -> dict[str, tuple[int, list[str]]]:
    entries: dict[str, tuple[int, list[str]]] = {}
    for line_no, line in enumerate(text.splitlines(), start=1):
        m = _KITTI_LINE.match(line)
        if m:
            entries[m.group(1)] = (line_no, m.group(2).split())
    return entries


def _kitti_projection(entries: dict[str, tuple[int, list[str]]], name: str) -> tuple[np.ndarray, str]:
    key = "P2" if "P2" in entries else "P_rect_02"
    if key not in entries:
        raise InputError(f"{name}: no P2 line; pass the KITTI calib file of the frame (calib/*.txt)")
    line_no, tokens = entries[key]
    where = f"{name} -> {key} (line {line_no})"
    if len(tokens) != 12:
        raise InputError(f"{where}: {len(tokens)} numbers, expected 12 (3x4 row-major)")
    try:
        P = np.array([float(t) for t in tokens]).reshape(3, 4)
    except ValueError as exc:
        raise InputError(f"{where}: {exc}; fix the numbers") from exc
    if not np.all(np.isfinite(P)):
        raise InputError(f"{where}: holds non-finite numbers; fix the calibration")
    if not (P[1, 0] == 0 and np.allclose(P[2, :3], [0.0, 0.0, 1.0])):
        raise InputError(
            f"{where}: P[:, :3] must be [[fx, s, cx], [0, fy, cy], [0, 0, 1]]; got {P[:, :3].tolist()}"
        )
    return P, where


def _parse_kitti(text: str, name: str) -> _Parsed:
    out = _Parsed("kitti")
    P, where = _kitti_projection(_kitti_entries(text, name), name)
    out.K = P[:, :3].copy()
    out.K_where = {
        k: f"{where}[{ij}] ({k})" for k, ij in (("fx", "0,0"), ("fy", "1,1"), ("cx", "0,2"), ("cy", "1,2"))
    }
    _check_intrinsics(out.K, out.K_where, None)  # bounded before K is inverted for the offset
    offset = cam2_offset_from_projection(P)
    if not np.all(np.abs(offset) <= MAX_CAMERA_HEIGHT_M):
        raise InputError(
            f"{where}: the camera offset t of P = K [I | t] is {offset.tolist()} m, beyond "
            f"{MAX_CAMERA_HEIGHT_M:g} m; check the fourth column of the matrix"
        )
    out.cam_offset = offset
    return out


def _parse_info(doc: Any, name: str, camera: str) -> _Parsed:
    if not is_info_document(doc):
        raise InputError(
            f"{name}: not an mmdetection3d info file (no data_list), so '#{camera}' names no camera; "
            "pass the camera file without '#'"
        )
    info = read_info_camera(doc, name, camera)
    out = _Parsed("info")
    out.K = info.K
    entries = (("fx", "0,0"), ("fy", "1,1"), ("cx", "0,2"), ("cy", "1,2"))
    out.K_where = {k: f"{info.K_where}[{ij}] ({k})" for k, ij in entries}
    if info.up_cam is not None and info.height_m is not None:
        if not info.height_m > 0:
            raise CalibrationError(
                f"{info.pose_where}: the camera is {info.height_m:g} m above the ground; must be > 0"
            )
        out.height_m, out.pitch, out.roll = pose_from_ground_plane(info.up_cam, info.height_m)
        out.where = {k: info.pose_where for k in ("height_m", "pitch", "roll")}
    return out


def _not_a_camera_file(text: str, name: str) -> InputError:
    """The error for a file no reader took: specific for a KITTI calib file without P2."""
    keys = list(_kitti_entries(text, name))
    if keys:
        return InputError(
            f"{name}: a KITTI-style calib file without a P2 line (it has {', '.join(keys[:6])}); "
            "usdworld reads camera 2, the left colour camera, from P2: pass the frame's full calib/<id>.txt"
        )
    return InputError(
        f"{name}: not a camera file usdworld knows; pass a Cityscapes camera JSON, a JSON with "
        "K / height_m / pitch_deg, a KITTI calib file with a P2 line or 'INFO.json#CAM_FRONT'"
    )


def read_kitti_projection(path: PathLike) -> np.ndarray:
    """The P2 matrix of a KITTI calib file (for evaluation against KITTI 3D labels).

    Args:
        path: KITTI calib text file.

    Returns:
        (3, 4) float64 P2, mapping rectified camera-0 points to camera-2 pixels.

    Raises:
        InputError: no P2 line or a malformed one.
    """
    data, file = read_input(path, "camera")
    return _kitti_projection(_kitti_entries(decode_text(data, file.name), file.name), file.name)[0]


def cam2_offset_from_projection(P: np.ndarray) -> np.ndarray:
    """Offset t of a rectified KITTI camera from camera 0, from ``P = K [I | t]``.

    Args:
        P: (3, 4) float64 projection matrix (P2).

    Returns:
        (3,) float64 t in metres: ``p_cam2 = p_cam0 + t``, both in the rectified frame
        (x right, y down, z forward); about (0.06, 0, 0) for KITTI camera 2.
    """
    P = np.asarray(P, dtype=np.float64)
    return np.linalg.solve(P[:, :3], P[:, 3])


# --- ground plane ---------------------------------------------------------------------


def read_plane(path: PathLike) -> tuple[np.ndarray, float, InputFile]:
    """A KITTI road-plane file: the plane ``a x + b y + c z + d = 0`` as written, in KITTI's
    rectified reference-camera frame (camera 0; :func:`cam2_offset_from_projection` moves it).

    Returns:
        ((3,) float64 normal (a, b, c) as written (KITTI writes a unit normal), d in metres, the
        file read).

    Raises:
        InputError: the file is not one plane line after the optional header, or its
            coefficients are not finite numbers.
    """
    data, file = read_input(path, "ground_plane")
    name = file.name
    rows = []
    for line_no, line in enumerate(decode_text(data, name).splitlines(), start=1):
        tokens = line.split()
        if not tokens or tokens[0].startswith("#"):
            continue
        key = tokens[0].lower()
        if key in ("width", "height"):
            expected = "4" if key == "width" else "1"
            if tokens[1:] != [expected]:
                raise InputError(f"{name}: line {line_no}: {line.strip()!r}, expected {tokens[0]} {expected}")
            continue
        rows.append((line_no, tokens))
    if len(rows) != 1 or len(rows[0][1]) != 4:
        raise InputError(
            f"{name}: expected one line 'a b c d' after the header; pass a KITTI planes/*.txt file"
        )
    line_no, tokens = rows[0]
    try:
        a, b, c, d = (float(t) for t in tokens)
    except ValueError as exc:
        raise InputError(f"{name}: line {line_no}: {exc}; fix the plane coefficients") from exc
    normal = np.array([a, b, c])
    if not all(math.isfinite(v) and abs(v) <= MAX_PLANE_COEFF for v in (a, b, c, d)):
        raise InputError(
            f"{name}: line {line_no}: plane coefficients must be finite and within +-{MAX_PLANE_COEFF:g}, "
            f"got {tokens}; KITTI writes a unit normal and d in metres"
        )
    if not np.linalg.norm(normal) > 0:
        raise InputError(f"{name}: line {line_no}: the plane normal (a, b, c) must be finite and non-zero")
    return normal, d, file


def pose_from_ground_plane(normal_cam: np.ndarray, d: float) -> tuple[float, float, float]:
    """Camera height, pitch and roll from the ground plane ``n . p_cam + d = 0``.

    The camera axes are OpenCV's (x right, y down, z forward). With the unit normal
    pointing from the ground towards the camera, ``up_cam``, the usdworld rotation
    (:func:`usdworld.frames.rotation_world_from_vehicle`) gives
    ``up_cam = (-sin(roll) cos(pitch), -cos(roll) cos(pitch), -sin(pitch))``.

    Args:
        normal_cam: (3,) float64 plane normal (a, b, c) in the camera frame, any length.
        d: plane offset.

    Returns:
        (height_m, pitch, roll): metres above the plane and radians (pitch positive looking down).

    Raises:
        CalibrationError: the camera lies on the plane.
    """
    n = np.asarray(normal_cam, dtype=np.float64)
    norm = float(np.linalg.norm(n))
    if d == 0 or norm == 0:
        raise CalibrationError(f"ground plane {n.tolist()}, d={d}: the camera lies on the plane")
    up = n * math.copysign(1.0, d) / norm
    pitch = math.asin(float(np.clip(-up[2], -1.0, 1.0)))
    roll = math.atan2(-up[0], -up[1])
    return abs(d) / norm, pitch, roll


# --- validation -----------------------------------------------------------------------


def _check_intrinsics(K: np.ndarray, where: dict[str, str], image: SourceImage | None) -> None:
    max_f = MAX_FOCAL_PX if image is None else min(MAX_FOCAL_PX, MAX_FOCAL_WIDTHS * image.width)
    for key, (r, c) in (("fx", (0, 0)), ("fy", (1, 1))):
        if not (math.isfinite(K[r, c]) and K[r, c] > 0):
            raise CalibrationError(f"{where[key]}: must be > 0, got {K[r, c]:g}")
        if not K[r, c] <= max_f:
            raise CalibrationError(
                f"{where[key]}: focal length {K[r, c]:g} px is beyond {max_f:g} px "
                f"({MAX_FOCAL_WIDTHS:g} image widths); focal lengths are in pixels, check the unit"
            )
    if not abs(K[0, 1]) <= max_f:
        raise CalibrationError(f"{where['fx']}: skew {K[0, 1]:g} must be within +-{max_f:g} px")
    for key, (r, c) in (("cx", (0, 2)), ("cy", (1, 2))):
        if not (math.isfinite(K[r, c]) and abs(K[r, c]) <= MAX_PIXEL_COORD):
            raise CalibrationError(
                f"{where[key]}: must be finite and within +-{MAX_PIXEL_COORD:g} px, got {K[r, c]:g}"
            )
    if image is None:
        return
    w, h = image.width, image.height
    cx, cy = float(K[0, 2]), float(K[1, 2])
    if not (-0.5 * w <= cx <= 1.5 * w and -0.5 * h <= cy <= 1.5 * h):
        size = f"about {2 * cx:.0f}x{2 * cy:.0f}" if cx > 0 and cy > 0 else "another size"
        scale = f" (about {w / (2 * cx):.3g})" if cx > 0 else ""
        raise CalibrationError(
            f"{where['cx']}: principal point ({cx:g}, {cy:g}) is far outside the {w}x{h} image "
            f"{image.file.name}, so the calibration is for an image of {size}; scale fx, fy, cx, cy by "
            f"the resize factor{scale} or pass the calibration of this image"
        )


def _warn_principal_point(K: np.ndarray, where: dict[str, str], image: SourceImage | None) -> None:
    """Warn about an odd principal point; called after every check that can fail, so an error stays one line."""
    if image is None:
        return
    w, h = image.width, image.height
    cx, cy = float(K[0, 2]), float(K[1, 2])
    if not (0 <= cx <= w and 0 <= cy <= h):
        logger.warning("%s: principal point (%g, %g) is outside the %dx%d image", where["cx"], cx, cy, w, h)
    elif abs(cx - w / 2) > 0.25 * w or abs(cy - h / 2) > 0.25 * h:
        logger.warning(
            "%s: principal point (%g, %g) is far from the centre of the %dx%d image; "
            "is the calibration for another resolution?",
            where["cx"],
            cx,
            cy,
            w,
            h,
        )


def _check_extrinsics(p: _Parsed) -> None:
    if p.height_m is not None and not (math.isfinite(p.height_m) and p.height_m > 0):
        raise CalibrationError(f"{p.where['height_m']}: camera height must be > 0 m, got {p.height_m:g}")
    if p.height_m is not None and not p.height_m <= MAX_CAMERA_HEIGHT_M:
        raise CalibrationError(
            f"{p.where['height_m']}: camera height must be <= {MAX_CAMERA_HEIGHT_M:g} m, got "
            f"{p.height_m:g}; heights are metres above the road"
        )
    for key in ("pitch", "roll"):
        value = getattr(p, key)
        if value is not None and not abs(math.degrees(value)) < MAX_TILT_DEG:
            raise CalibrationError(
                f"{p.where[key]}: {key} must be within +-{MAX_TILT_DEG:g} degrees, got "
                f"{math.degrees(value):.1f} degrees; check its sign and units"
            )
    if p.yaw is not None:
        check_range(
            math.degrees(p.yaw), -MAX_YAW_DEG, MAX_YAW_DEG, p.where["yaw"], "degrees", "check its unit"
        )


# --- entry point ----------------------------------------------------------------------


def read_camera(
    path: PathLike, image: SourceImage | None = None, planes_path: PathLike | None = None
) -> CameraSpec:
    """Read a Cityscapes camera JSON, a KITTI calib file, a plain camera JSON or one camera of an info file.

    Args:
        path: the camera file (format recognised from its content), or ``INFO.json#CAMERA``.
        image: the photo; when given, the principal point must fit its size.
        planes_path: optional KITTI ground-plane file giving height, pitch and roll.

    Returns:
        CameraSpec with ``K`` (3, 3) float64 or None, height/pitch/roll/yaw or None
        (radians), ``source`` (``cityscapes``, ``kitti``, ``plain`` or ``info``), the camera
        file (role ``camera``; an info file's name ends in ``#CAMERA``) and the planes file
        in ``extra_files`` (role ``ground_plane``).

    Raises:
        InputError: unrecognised or malformed file, a missing field (named by its path),
            or a planes file given with a camera file that has extrinsics.
        CalibrationError: fx or fy <= 0, a principal point far outside the image,
            height <= 0, or |pitch| or |roll| >= 45 degrees.
    """
    file_path, info_camera = split_camera_ref(path)
    data, file = read_input(file_path, "camera")
    name = file.name
    if is_pickle(data):
        raise InputError(pickle_message(name))
    text = decode_text(data, name)
    if info_camera is not None:
        parsed = _parse_info(parse_info_json(data, name), name, info_camera)
        file = replace(file, name=f"{name}#{info_camera}")
    elif text.lstrip().startswith("{"):
        if '"data_list"' in text:  # an info file, which may hold NaN: read as evaluate --gt reads it
            info = parse_info_json(data, name)
            if is_info_document(info):
                raise InputError(info_without_camera_message(info, name))
        doc = as_object(parse_json(data, name), name)
        parsed = (
            _parse_cityscapes(doc, name)
            if ("intrinsic" in doc or "extrinsic" in doc)
            else _parse_plain(doc, name)
        )
    elif any(k in _kitti_entries(text, name) for k in ("P2", "P_rect_02")):
        parsed = _parse_kitti(text, name)
    else:
        raise _not_a_camera_file(text, name)

    extra: tuple[InputFile, ...] = ()
    if planes_path is not None:
        given = [k for k in ("height_m", "pitch", "roll") if getattr(parsed, k) is not None]
        if given:
            raise InputError(
                f"{name}: already gives {parsed.where[given[0]].split(' -> ', 1)[1]}; "
                "a ground-plane file is only for camera files without extrinsics, pass one of the two"
            )
        normal, d, plane_file = read_plane(planes_path)
        if parsed.cam_offset is not None:
            d = d - float(normal @ parsed.cam_offset)  # the plane seen from camera 2, not camera 0
        parsed.height_m, parsed.pitch, parsed.roll = pose_from_ground_plane(normal, d)
        parsed.where |= {k: f"{plane_file.name} -> plane" for k in ("height_m", "pitch", "roll")}
        extra = (plane_file,)

    if parsed.K is not None:
        _check_intrinsics(parsed.K, parsed.K_where, image)
    _check_extrinsics(parsed)
    if parsed.K is not None:
        _warn_principal_point(parsed.K, parsed.K_where, image)
    return CameraSpec(
        K=parsed.K,
        height_m=parsed.height_m,
        pitch=parsed.pitch,
        roll=parsed.roll,
        yaw=parsed.yaw,
        source=parsed.source,
        file=file,
        extra_files=extra,
    )
