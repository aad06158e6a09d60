"""Read and write dense metric depth maps.

Readable formats, recognised from the file's first bytes:

* ``.npy``: (H, W) float array of metres (``numpy.save``; pickles are refused);
* 16-bit greyscale PNG, KITTI convention: metres * 256, 0 = no depth;
* PFM (``Pf``, single channel, float32): a negative scale means little-endian; rows
  are stored bottom to top.

NaN, infinite, non-positive values and values beyond :data:`MAX_FILE_DEPTH_M` are
marked invalid and set to 0; they never reach later stages. A map may hold at most
:data:`~usdworld.io.limits.MAX_PIXELS` pixels. Depth is along the optical axis, not the ray length.

Example:
    >>> write_depth_png16("d.png", depth_m)  # doctest: +SKIP
    >>> read_depth("d.png").depth_m  # doctest: +SKIP
"""

from __future__ import annotations

import io
import math
import re
from pathlib import Path

import cv2
import numpy as np

from usdworld.atomic import write_bytes_atomic
from usdworld.errors import InputError, OutputError
from usdworld.io.hashing import PathLike, read_input
from usdworld.io.images import decode_unchanged, sniff_format
from usdworld.io.limits import MAX_PIXELS
from usdworld.io.types import DepthMap, SourceImage

#: KITTI depth PNG scale: stored value = metres * 256.
PNG_DEPTH_SCALE = 256.0
MAX_PNG_DEPTH_M = 65535 / PNG_DEPTH_SCALE
#: Farthest depth read from a file, metres: no street photo shows measurable depth past
#: 10 km, and larger values (1e30 in a float .npy) would overflow later float32 sums.
MAX_FILE_DEPTH_M = 10_000.0

_PFM_HEADER = re.compile(rb"^(P[Ff])\s+(\d+)\s+(\d+)\s+([-+0-9.eE]+)(?:\r\n|\s)")


def _check_npy_header(data: bytes, name: str) -> None:
    """Refuse a .npy whose header promises more samples than the file holds or than allowed.

    ``np.load`` allocates the whole declared array before reading, so a 100-byte file
    declaring 10^10 samples would ask for 80 GB.
    """
    f = io.BytesIO(data)
    try:
        version = np.lib.format.read_magic(f)
        reader = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}
        if version not in reader:
            raise ValueError(f"format version {version[0]}.{version[1]}; save with numpy.save")
        shape, _, dtype = reader[version](f)
    except (ValueError, TypeError, SyntaxError) as exc:
        raise InputError(f"{name}: not a plain numeric .npy array ({exc}); save it with numpy.save") from exc
    count = math.prod(int(n) for n in shape)
    if count > 3 * MAX_PIXELS:
        raise InputError(f"{name}: array of shape {tuple(shape)} is more than {MAX_PIXELS} pixels")
    if count * dtype.itemsize > len(data) - f.tell():
        raise InputError(
            f"{name}: the header declares shape {tuple(shape)} but the file is shorter; save it again"
        )


def _read_npy(data: bytes, name: str) -> np.ndarray:
    _check_npy_header(data, name)
    try:
        arr = np.load(io.BytesIO(data), allow_pickle=False)
    except ValueError as exc:  # pickled object arrays, bad header
        raise InputError(f"{name}: not a plain numeric .npy array ({exc}); save it with numpy.save") from exc
    except (OSError, EOFError) as exc:
        raise InputError(f"{name}: the .npy file is truncated or corrupt ({exc}); save it again") from exc
    if not isinstance(arr, np.ndarray):
        raise InputError(f"{name}: holds several arrays; save one (H, W) array with numpy.save")
    if arr.ndim == 3 and 1 in (arr.shape[0], arr.shape[2]):
        arr = arr.reshape(arr.shape[1:] if arr.shape[0] == 1 else arr.shape[:2])
    if arr.ndim != 2:
        raise InputError(f"{name}: array of shape {arr.shape}; a depth map must be (H, W)")
    if arr.size > MAX_PIXELS:
        raise InputError(f"{name}: {arr.shape[1]}x{arr.shape[0]} is more than {MAX_PIXELS} pixels")
    if arr.dtype.kind != "f":
        raise InputError(
            f"{name}: dtype {arr.dtype}; .npy depth must be float metres "
            "(save integer KITTI-style depth as a 16-bit PNG instead)"
        )
    return arr


def _read_png(data: bytes, name: str) -> np.ndarray:
    what = "a 16-bit greyscale depth PNG (metres * 256)"
    arr = decode_unchanged(data, name, what)
    if arr.ndim == 3:
        raise InputError(
            f"{name}: a {arr.shape[2]}-channel colour image (a depth visualisation?); pass {what}"
        )
    if arr.dtype != np.uint16:
        raise InputError(f"{name}: {arr.dtype} samples where 16-bit are expected; pass {what}")
    return arr.astype(np.float32) / PNG_DEPTH_SCALE


def _read_pfm(data: bytes, name: str) -> np.ndarray:
    m = _PFM_HEADER.match(data[:256])
    if m is None:
        raise InputError(f"{name}: malformed PFM header; expected 'Pf', 'W H' and the scale on three lines")
    if m.group(1) == b"PF":
        raise InputError(f"{name}: a 3-channel PFM; pass a single-channel (Pf) depth map")
    width, height = int(m.group(2)), int(m.group(3))
    if width * height > MAX_PIXELS:
        raise InputError(f"{name}: PFM header gives {width}x{height}, more than {MAX_PIXELS} pixels; fix the header")
    try:
        scale = float(m.group(4))
    except ValueError as exc:
        raise InputError(f"{name}: PFM scale {m.group(4)!r} is not a number; fix the header") from exc
    if scale == 0 or width == 0 or height == 0:
        raise InputError(
            f"{name}: PFM header gives size {width}x{height} and scale {scale:g}; fix the header"
        )
    payload = data[m.end() :]
    expected = width * height * 4
    if len(payload) != expected:
        raise InputError(
            f"{name}: {len(payload)} bytes of samples but the header says {width}x{height} floats "
            f"({expected} bytes); the file is truncated or its header is wrong"
        )
    dtype = "<f4" if scale < 0 else ">f4"
    return np.flipud(np.frombuffer(payload, dtype=dtype).reshape(height, width))


def read_depth(path: PathLike, image: SourceImage | None = None) -> DepthMap:
    """Read a metric depth map (.npy, 16-bit PNG or PFM).

    Args:
        path: the depth file.
        image: the photo; when given, the depth map must have its size.

    Returns:
        DepthMap with ``depth_m`` (H, W) float32 (0 where invalid), ``valid`` (H, W) bool
        and ``source`` = ``file:<name>``.

    Raises:
        InputError: missing, unsupported or corrupt file, wrong dtype or shape, a size
            that differs from the image, or no valid depth at all.
    """
    data, file = read_input(path, "depth")
    name = file.name
    fmt = sniff_format(data)
    if fmt == "NumPy .npy":
        raw = _read_npy(data, name)
    elif fmt == "PNG":
        raw = _read_png(data, name)
    elif fmt == "PFM":
        raw = _read_pfm(data, name)
    else:
        kind = "an unknown format" if fmt == "unknown" else f"a {fmt} file"
        raise InputError(f"{name}: is {kind}; pass depth as .npy (float metres), 16-bit PNG or PFM")
    if raw.shape[0] == 0 or raw.shape[1] == 0:
        raise InputError(f"{name}: the depth map has zero size ({raw.shape[1]}x{raw.shape[0]})")
    if image is not None and raw.shape != (image.height, image.width):
        raise InputError(
            f"{name}: depth is {raw.shape[1]}x{raw.shape[0]} but the image {image.file.name} is "
            f"{image.width}x{image.height}; pass the depth of the same frame at the image resolution"
        )
    with np.errstate(over="ignore", invalid="ignore"):
        depth = raw.astype(np.float32)
        valid = np.isfinite(depth) & (depth > 0) & (depth <= MAX_FILE_DEPTH_M)
    if not valid.any():
        raise InputError(
            f"{name}: no valid depth (every value is NaN, infinite, <= 0 or beyond {MAX_FILE_DEPTH_M:g} m); "
            "pass a real depth map in metres"
        )
    depth[~valid] = 0.0
    return DepthMap(depth_m=depth, valid=valid, source=f"file:{name}")


def _as_depth_2d(depth: np.ndarray, target: PathLike) -> np.ndarray:
    arr = np.asarray(depth)
    if arr.ndim != 2 or arr.size == 0 or arr.dtype.kind not in "fiu":
        raise OutputError(
            f"{Path(target).name}: depth must be a non-empty (H, W) numeric array, got {arr.shape}"
        )
    return arr


def write_depth_png16(path: PathLike, depth_m: np.ndarray) -> None:
    """Write depth as a KITTI-style 16-bit PNG (metres * 256, 0 = invalid), atomically.

    Args:
        path: output file.
        depth_m: (H, W) float depth in metres; NaN, inf and <= 0 are written as 0, and
            valid depths below 1/256 m as 1 (the smallest storable depth).

    Raises:
        OutputError: depth above 255.99 m, a bad array, or the file cannot be written.
    """
    arr = _as_depth_2d(depth_m, path).astype(np.float64)
    valid = np.isfinite(arr) & (arr > 0)
    if valid.any() and arr[valid].max() > MAX_PNG_DEPTH_M:
        raise OutputError(
            f"{Path(path).name}: depth up to {arr[valid].max():.1f} m does not fit a 16-bit PNG "
            f"(max {MAX_PNG_DEPTH_M:.2f} m); clip the depth or write .npy / PFM"
        )
    stored = np.zeros(arr.shape, dtype=np.uint16)
    stored[valid] = np.clip(np.round(arr[valid] * PNG_DEPTH_SCALE), 1, 65535).astype(np.uint16)
    ok, buf = cv2.imencode(".png", stored)
    if not ok:
        raise OutputError(f"{Path(path).name}: OpenCV could not encode the PNG")
    write_bytes_atomic(path, buf.tobytes())


def write_pfm(path: PathLike, depth: np.ndarray) -> None:
    """Write a single-channel little-endian PFM (rows bottom to top), atomically.

    Args:
        path: output file.
        depth: (H, W) float depth in metres; values are written as float32 unchanged.

    Raises:
        OutputError: a bad array or the file cannot be written.
    """
    arr = _as_depth_2d(depth, path).astype("<f4")
    height, width = arr.shape
    header = f"Pf\n{width} {height}\n-1.0\n".encode("ascii")
    write_bytes_atomic(path, header + np.ascontiguousarray(np.flipud(arr)).tobytes())
