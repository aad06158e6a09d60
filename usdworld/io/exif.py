"""The focal length a photo's EXIF states, in pixels of the photo as it is.

Read through Pillow. In order of preference:

1. ``FocalLengthIn35mmFilm`` (tag 0xA405): the focal length a 36 x 24 mm frame would
   need for the same field of view. The standard (CIPA DC-008, EXIF 2.3, section
   4.6.5) defines the equivalence on the diagonal (43.27 mm), so
   ``f_px = f35 * hypot(W, H) / 43.27``; this holds for any aspect ratio and crop the
   camera itself made.
2. ``FocalLength`` (0x920A, mm) with ``FocalPlaneXResolution`` (0xA20E) and
   ``FocalPlaneResolutionUnit`` (0xA210; 2 inch, 3 cm, 4 mm, 5 um): pixels per unit on the
   sensor at the resolution of ``PixelXDimension`` (0xA002, else the image width);
   ``f_px = f_mm * res_per_mm * W / PixelXDimension``.

Photos resized after capture keep the tags; (1) scales with the image, (2) is rescaled by
the ratio of the image width to ``PixelXDimension``. Tags that are missing, zero or not
numbers give no focal length (the photo's other cues and the prior decide).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

log = logging.getLogger(__name__)

#: Diagonal of a 36 x 24 mm frame, millimetres.
FILM_DIAGONAL_MM = 43.2666

_EXIF_IFD = 0x8769
_FOCAL_LENGTH = 0x920A
_FOCAL_35MM = 0xA405
_PLANE_X_RES = 0xA20E
_PLANE_UNIT = 0xA210
_PIXEL_X_DIM = 0xA002
_MM_PER_UNIT = {1: 25.4, 2: 25.4, 3: 10.0, 4: 1.0, 5: 1e-3}


@dataclass(frozen=True)
class ExifFocal:
    """A focal length from EXIF.

    Attributes:
        f_px: focal length in pixels of the image as read.
        tag: which tags gave it (``FocalLengthIn35mmFilm`` or ``FocalLength+FocalPlaneXResolution``).
        detail: the values read, for the provenance.
    """

    f_px: float
    tag: str
    detail: str


def _number(value: object) -> float | None:
    try:
        x = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError, ZeroDivisionError):
        return None
    return x if x > 0 and x == x and x != float("inf") else None


def focal_from_tags(tags: dict[int, object], width: int, height: int) -> ExifFocal | None:
    """The focal length in pixels from EXIF tags (module docstring).

    Args:
        tags: EXIF tag id -> value (the Exif IFD's tags merged with the main IFD's).
        width: image width, pixels.
        height: image height, pixels.

    Returns:
        The focal length, or None when the tags do not give one.
    """
    f35 = _number(tags.get(_FOCAL_35MM))
    if f35 is not None:
        f_px = f35 * float((width**2 + height**2) ** 0.5) / FILM_DIAGONAL_MM
        return ExifFocal(f_px, "FocalLengthIn35mmFilm", f"EXIF 35 mm-equivalent focal length {f35:g} mm")
    f_mm = _number(tags.get(_FOCAL_LENGTH))
    res = _number(tags.get(_PLANE_X_RES))
    unit = tags.get(_PLANE_UNIT, 2)
    if f_mm is None or res is None or unit not in _MM_PER_UNIT:
        return None
    px_per_mm = res / _MM_PER_UNIT[int(unit)]  # type: ignore[call-overload]
    full_width = _number(tags.get(_PIXEL_X_DIM)) or float(width)
    f_px = f_mm * px_per_mm * width / full_width
    return ExifFocal(
        f_px,
        "FocalLength+FocalPlaneXResolution",
        f"EXIF focal length {f_mm:g} mm at {px_per_mm:.1f} px/mm on the sensor",
    )


def read_exif_focal(path: Path, width: int, height: int) -> ExifFocal | None:
    """The focal length the photo's EXIF states, in pixels of a ``width`` x ``height`` image.

    Args:
        path: the photo.
        width: width of the image as used, pixels.
        height: its height, pixels.

    Returns:
        The focal length, or None when the file has no usable EXIF (or is not readable by Pillow).
    """
    from PIL import Image, UnidentifiedImageError  # 25 ms to import: only when a camera is estimated

    try:
        with Image.open(path) as image:
            exif = image.getexif()
            tags: dict[int, object] = dict(exif.items())
            tags.update(exif.get_ifd(_EXIF_IFD).items())
    except (OSError, UnidentifiedImageError, ValueError) as exc:
        log.debug("%s: no EXIF read (%s)", path, exc)
        return None
    return focal_from_tags(tags, width, height)
