"""Read the source photo (PNG or JPEG) into an RGB :class:`SourceImage`.

Greyscale photos are expanded to RGB, an alpha channel is dropped, and 16-bit PNGs
are scaled to 8 bits (``round(v * 255 / 65535)``). JPEG EXIF orientation is applied,
so the pixels are what an image viewer shows. The format is recognised from the
file's first bytes, not its extension. Decoding happens with the process's native stderr
captured (:func:`native_stderr_captured`), so libpng's and OpenCV's own warnings about a
damaged file go to the debug log instead of preceding the one-line error.

Example:
    >>> image = read_image("street.jpg")  # doctest: +SKIP
    >>> image.rgb.shape, image.rgb.dtype  # doctest: +SKIP
    ((1024, 2048, 3), dtype('uint8'))
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys
import tempfile
import threading
from collections.abc import Iterator
from typing import IO

import cv2
import numpy as np

from usdworld.errors import InputError
from usdworld.io.hashing import PathLike, read_input
from usdworld.io.limits import MAX_PIXELS
from usdworld.io.types import SourceImage

logger = logging.getLogger(__name__)

_STDERR_LOCK = threading.Lock()

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
JPEG_SIGNATURE = b"\xff\xd8\xff"

#: PNG IHDR colour types (PNG spec, section 11.2.2).
PNG_COLOR_TYPES = {0: "greyscale", 2: "RGB", 3: "palette", 4: "greyscale+alpha", 6: "RGBA"}

_OTHER_FORMATS: tuple[tuple[bytes, int, str], ...] = (
    (b"GIF8", 0, "GIF"),
    (b"BM", 0, "BMP"),
    (b"II*\x00", 0, "TIFF"),
    (b"MM\x00*", 0, "TIFF"),
    (b"WEBP", 8, "WebP"),
    (b"ftypheic", 4, "HEIC"),
    (b"ftypheix", 4, "HEIC"),
    (b"ftypmif1", 4, "HEIF"),
    (b"ftypavif", 4, "AVIF"),
    (b"v/1\x01", 0, "OpenEXR"),
    (b"\x93NUMPY", 0, "NumPy .npy"),
    (b"Pf", 0, "PFM"),
    (b"PF", 0, "PFM"),
)


def sniff_format(data: bytes) -> str:
    """Name of the file format from its first bytes.

    Returns:
        ``PNG``, ``JPEG``, another known name (``TIFF``, ``HEIC`` ...) or ``unknown``.
    """
    if data.startswith(PNG_SIGNATURE):
        return "PNG"
    if data.startswith(JPEG_SIGNATURE):
        return "JPEG"
    for magic, offset, fmt in _OTHER_FORMATS:
        if data[offset : offset + len(magic)] == magic:
            return fmt
    return "unknown"


def png_header(data: bytes) -> tuple[int, int, int, int]:
    """Width, height, bit depth and colour type from a PNG's IHDR chunk.

    Args:
        data: bytes of a file that starts with the PNG signature.

    Returns:
        (width, height, bit_depth, color_type); all 0 when the header is cut short.
    """
    if len(data) < 26 or data[12:16] != b"IHDR":
        return (0, 0, 0, 0)
    width = int.from_bytes(data[16:20], "big")
    height = int.from_bytes(data[20:24], "big")
    return (width, height, data[24], data[25])


class _SharedCapture:
    """The one swap of descriptor 2 that the blocks of :func:`native_stderr_captured` running at
    the same time share (guarded by ``_STDERR_LOCK``): the first to enter swaps it, the last to
    leave restores it.

    Attributes:
        users: blocks inside now.
        saved: the duplicate of the process's own descriptor 2 while swapped, else None.
        sink: the temporary file descriptor 2 points at while swapped.
        names: what each block of this swap decodes, in the order they entered.
    """

    def __init__(self) -> None:
        self.users = 0
        self.saved: int | None = None
        self.sink: IO[bytes] | None = None
        self.names: list[str] = []


_CAPTURE = _SharedCapture()


@contextlib.contextmanager
def native_stderr_captured(what: str) -> Iterator[None]:
    """Send what C libraries write to file descriptor 2 to the debug log instead.

    libpng (``libpng warning: iCCP: ...``, ``libpng error: IDAT: CRC error``) and OpenCV's
    decoders print straight to the process's stderr, below Python's ``sys.stderr``. The
    descriptor is pointed at a temporary file for the duration and restored after. Blocks on
    several threads at once share one swap (a build decodes the photo and its labels side by
    side, :mod:`usdworld.stage_threads`): the first to enter swaps the descriptor, the last to
    leave restores it and logs what was written, under the names of every block that shared it.
    Where descriptor 2 cannot be swapped (no such descriptor), the block runs unchanged.

    Args:
        what: name for the debug log line (the file being decoded).
    """
    with _STDERR_LOCK:
        if _CAPTURE.users == 0:
            try:
                sys.stderr.flush()
                saved = os.dup(2)
            except (OSError, ValueError, AttributeError):
                saved = None
            if saved is not None:
                sink = tempfile.TemporaryFile()
                os.dup2(sink.fileno(), 2)
                _CAPTURE.saved, _CAPTURE.sink = saved, sink
        swapped = _CAPTURE.saved is not None
        if swapped:
            _CAPTURE.users += 1
            _CAPTURE.names.append(what)
    if not swapped:
        yield
        return
    try:
        yield
    finally:
        text, names = "", ""
        with _STDERR_LOCK:
            _CAPTURE.users -= 1
            if _CAPTURE.users == 0 and _CAPTURE.saved is not None and _CAPTURE.sink is not None:
                os.dup2(_CAPTURE.saved, 2)
                os.close(_CAPTURE.saved)
                _CAPTURE.sink.seek(0)
                text = _CAPTURE.sink.read(4096).decode("utf-8", "replace").strip()
                _CAPTURE.sink.close()
                names = ", ".join(_CAPTURE.names)
                _CAPTURE.saved, _CAPTURE.sink, _CAPTURE.names = None, None, []
        if text:
            logger.debug("%s: the decoder said: %s", names, text.replace("\n", " | "))


def decode_unchanged(data: bytes, name: str, what: str) -> np.ndarray:
    """Decode PNG or JPEG bytes without any conversion (OpenCV ``IMREAD_UNCHANGED``).

    Args:
        data: the file's bytes.
        name: file name for error messages.
        what: what the file should be, for the fix hint (``an 8-bit labelIds PNG`` ...).

    Returns:
        (H, W) or (H, W, C) array, uint8 or uint16, channels in BGR(A) order.

    Raises:
        InputError: unsupported format, corrupt data, or zero size.
    """
    fmt = sniff_format(data)
    if fmt not in ("PNG", "JPEG"):
        kind = "an unknown format" if fmt == "unknown" else f"a {fmt} file"
        raise InputError(f"{name}: is {kind}, not PNG or JPEG; pass {what}")
    return _decode(data, name, fmt, cv2.IMREAD_UNCHANGED)


def _decode(data: bytes, name: str, fmt: str, flags: int) -> np.ndarray:
    if fmt == "PNG":
        width, height = png_header(data)[:2]
        if width * height > MAX_PIXELS:
            raise InputError(
                f"{name}: the PNG header gives {width}x{height}, more than {MAX_PIXELS} pixels; pass a smaller image"
            )
    buf = np.frombuffer(data, dtype=np.uint8)
    try:
        with native_stderr_captured(name):
            img = cv2.imdecode(buf, flags)
    except cv2.error as exc:
        raise InputError(
            f"{name}: the {fmt} data cannot be decoded ({str(exc).strip().splitlines()[-1]}); "
            "re-export the file"
        ) from exc
    if img is None:
        raise InputError(
            f"{name}: the {fmt} data is corrupt or truncated and cannot be decoded; "
            "re-export or re-download the file"
        )
    if img.size == 0 or img.shape[0] == 0 or img.shape[1] == 0:
        raise InputError(
            f"{name}: the image has zero size ({img.shape[1]}x{img.shape[0]}); pass a real image"
        )
    return img


def _to_rgb8(img: np.ndarray, name: str) -> np.ndarray:
    """Convert an (H, W) / (H, W, 1|3|4) uint8/uint16 BGR(A) array to (H, W, 3) uint8 RGB."""
    if img.dtype == np.uint16:
        img = ((img.astype(np.uint32) * 255 + 32767) // 65535).astype(np.uint8)
    elif img.dtype != np.uint8:
        raise InputError(f"{name}: unsupported sample type {img.dtype}; save the image as 8-bit PNG or JPEG")
    if img.ndim == 3 and img.shape[2] == 1:
        img = img[:, :, 0]
    if img.ndim == 2:
        return np.ascontiguousarray(np.repeat(img[:, :, None], 3, axis=2))
    channels = img.shape[2]
    if channels == 3:
        return cv2.cvtColor(img, cv2.COLOR_BGR2RGB)
    if channels == 4:
        return cv2.cvtColor(img, cv2.COLOR_BGRA2RGB)
    if channels == 2:  # greyscale + alpha
        return np.ascontiguousarray(np.repeat(img[:, :, :1], 3, axis=2))
    raise InputError(f"{name}: {channels} colour channels are not supported; save the image as RGB")


def read_image(path: PathLike) -> SourceImage:
    """Read a PNG or JPEG photo.

    Args:
        path: the photo, any size; greyscale, RGB or RGBA; 8 or 16 bits per sample.

    Returns:
        SourceImage with ``rgb`` (H, W, 3) uint8 in RGB order and ``file.role == "image"``.

    Raises:
        InputError: the file is missing, empty, not PNG/JPEG, corrupt, or has zero size.
    """
    data, file = read_input(path, "image")
    fmt = sniff_format(data)
    if fmt not in ("PNG", "JPEG"):
        kind = "an unknown format" if fmt == "unknown" else f"a {fmt} file"
        raise InputError(f"{file.name}: is {kind}, not a PNG or JPEG image; convert the photo to PNG or JPEG")
    if fmt == "JPEG":
        if data.rfind(b"\xff\xd9") < 0:  # libjpeg decodes a cut-off file with grey rows, silently
            raise InputError(
                f"{file.name}: the JPEG has no end-of-image marker (truncated file); "
                "re-export or re-download the photo"
            )
        # IMREAD_COLOR applies the EXIF orientation and always gives 8-bit BGR.
        bgr = _decode(data, file.name, fmt, cv2.IMREAD_COLOR)
        rgb = _to_rgb8(bgr, file.name)
    else:
        rgb = _to_rgb8(_decode(data, file.name, fmt, cv2.IMREAD_UNCHANGED), file.name)
    rgb.setflags(write=False)  # this reader's own array: SourceImage keeps it without a copy
    return SourceImage(rgb=rgb, file=file)
