"""An object's colour measured from its own pixels in the photo.

The colour of a region is a *trimmed median* in linear RGB:

1. the region's darkest and brightest pixels by luminance are left out (cast shadows,
   tyres and window interiors; specular highlights): ``colour_trim_dark`` and
   ``colour_trim_bright`` of :class:`~usdworld.parameters.perception.PerceptionParams`;
2. the dominant colour is the densest neighbourhood of a CIELAB histogram of the rest
   (bins of ``colour_bin_lab``, summed over 3x3x3 bins);
3. the pixels within ``colour_radius_lab`` (CIE76) of it are kept, the dominant colour is
   re-centred on their median and they are chosen again; the result is their per-channel
   median and spread (1.4826 x the median absolute deviation: the standard deviation of
   normally distributed values).

An object's region is its instance mask where it has one; a box-only object's is its box
minus the boxes of the objects nearer the camera (occluders). Both are limited to the box
shrunk by ``colour_inner_margin`` (and, for classes whose body colour lies in a band of their
height, such as a car's below its windows, to that band) when that leaves enough pixels.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from usdworld.parameters.perception import DEFAULT_PERCEPTION, PerceptionParams
from usdworld.perception.colour_space import linear_to_lab, uint8_to_linear

#: Rec. 709 luminance weights of linear RGB.
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
#: Where a colour's pixels can come from (:attr:`MeasuredColour.region`).
REGIONS = ("mask", "box", "labels", "inferred", "ground")
#: Median absolute deviation -> standard deviation of a normal distribution.
MAD_TO_SIGMA = 1.4826


@dataclass(frozen=True)
class MeasuredColour:
    """A region's colour in the photo.

    Attributes:
        linear_rgb: (3,) float64 trimmed median, linear RGB in [0, 1].
        spread: (3,) float64 robust standard deviation of the kept pixels per channel, linear RGB.
        pixels: number of pixels the median was taken over.
        region: where the pixels came from: ``mask``, ``box`` (minus nearer boxes), ``labels``
            (a label map's region) or ``ground`` (the ground below the horizon outside every box).
    """

    linear_rgb: np.ndarray
    spread: np.ndarray
    pixels: int
    region: str

    def __post_init__(self) -> None:
        for name in ("linear_rgb", "spread"):
            a = np.array(getattr(self, name), dtype=np.float64)
            if a.shape != (3,) or not np.all(np.isfinite(a)):
                raise ValueError(f"MeasuredColour.{name}: must be 3 finite numbers, got {a}")
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        if self.pixels < 1:
            raise ValueError(f"MeasuredColour.pixels: must be >= 1, got {self.pixels}")
        if self.region not in REGIONS:
            raise ValueError(f"MeasuredColour.region: one of {REGIONS}, got {self.region!r}")


def trimmed_colour(
    linear: np.ndarray, region: str, params: PerceptionParams = DEFAULT_PERCEPTION
) -> MeasuredColour:
    """The trimmed median colour of a set of pixels (module docstring).

    Args:
        linear: (N, 3) float linear RGB pixels, N >= 1.
        region: recorded in the result (one of :data:`REGIONS`).
        params: ``colour_*`` fields.

    Returns:
        The colour, its spread and the number of pixels kept.

    Raises:
        ValueError: no pixels.
    """
    px = np.asarray(linear, dtype=np.float64).reshape(-1, 3)
    if len(px) == 0:
        raise ValueError("trimmed_colour: no pixels")
    if len(px) > params.colour_max_samples:
        px = px[np.linspace(0, len(px) - 1, params.colour_max_samples).astype(np.int64)]
    lum = px @ LUMINANCE
    lo, hi = np.quantile(lum, [params.colour_trim_dark, 1.0 - params.colour_trim_bright])
    kept = px[(lum >= lo) & (lum <= hi)]
    if len(kept) == 0:
        kept = px
    lab = linear_to_lab(kept)
    # channel by channel, each channel contiguous: the same numbers as along the (N, 3) arrays' first axis
    lab_c = np.ascontiguousarray(lab.T)
    centre = _dominant_lab(lab, params.colour_bin_lab, lab_c)
    for _ in range(2):
        step = lab_c - centre[:, None]
        step *= step
        # CIE76, the squares added in np.linalg.norm's order
        near = np.sqrt(step[0] + step[1] + step[2]) <= params.colour_radius_lab
        if not near.any():
            near = np.ones(len(lab), dtype=bool)
        centre = np.median(lab_c[:, near], axis=1)
    chosen = np.ascontiguousarray(kept.T)[:, near]
    median = np.median(chosen, axis=1)
    spread = MAD_TO_SIGMA * np.median(np.abs(chosen - median[:, None]), axis=1)
    chosen_count = int(np.count_nonzero(near))
    return MeasuredColour(np.clip(median, 0.0, 1.0), spread, chosen_count, region)


def sampled_pixels(rgb: np.ndarray, region: np.ndarray, max_samples: int) -> np.ndarray:
    """(N, 3) uint8 the region's pixels, as ``rgb[region]``, or the regular subsample of them
    that :func:`trimmed_colour` takes when there are more than ``max_samples``.

    Only those pixels are gathered and decoded: ``trimmed_colour(uint8_to_linear(...))`` of them
    is bit for bit that of all the region's pixels.

    Args:
        rgb: (H, W, 3) uint8 sRGB pixels.
        region: (H, W) bool.
        max_samples: ``colour_max_samples``.
    """
    flat = np.flatnonzero(region)  # row-major, as np.nonzero's pairs; one index array, not two
    if len(flat) > max_samples:
        flat = flat[np.linspace(0, len(flat) - 1, max_samples).astype(np.int64)]
    rows, cols = np.divmod(flat, region.shape[1])
    return rgb[rows, cols]


def box_mean3(values: np.ndarray) -> np.ndarray:
    """The mean of each cell's 3x...x3 neighbourhood, cells outside the array counting 0.

    ``scipy.ndimage.uniform_filter(values, size=3, mode="constant")`` bit for bit (scipy 1.17),
    by its own steps: along each axis in turn, a running sum started from the first three
    cells (the one before the line counting 0), moved by ``entering - leaving`` one cell at
    a time (here ``np.cumsum``, which adds in the same order) and divided by 3. Without
    scipy: importing ``scipy.ndimage`` cost the ``build`` command about 0.2 s of its start-up
    (the test pins the equality).

    Args:
        values: (...) float64 array, every axis at least 1 long.

    Returns:
        Float64 array of the same shape.
    """
    out = np.asarray(values, dtype=np.float64)
    for axis in range(out.ndim):
        line = np.moveaxis(out, axis, 0)  # a view: the axis filtered first
        n = len(line)
        # sums[0]: the cell before the line (0) and the first two; sums[l]: + entering - leaving
        sums = np.empty(line.shape)
        sums[0] = 0.0 + line[0] + (line[1] if n > 1 else 0.0)
        if n > 1:
            entering = np.zeros((n - 1,) + line.shape[1:])
            entering[: n - 2] = line[2:]
            leaving = np.zeros_like(entering)
            leaving[1:] = line[: n - 2]
            np.subtract(entering, leaving, out=sums[1:])
        np.cumsum(sums, axis=0, out=sums)
        sums /= 3.0
        out = np.moveaxis(sums, 0, axis)
    return out


def _dominant_lab(lab: np.ndarray, bin_size: float, lab_c: np.ndarray | None = None) -> np.ndarray:
    """(3,) mean CIELAB of the pixels in the densest 3x3x3-bin neighbourhood of a histogram.

    Args:
        lab: (N, 3) float64 CIELAB pixels.
        bin_size: the bins' side.
        lab_c: (3, N) the same, channel by channel (contiguous rows: faster), or None.
    """
    lab_c = np.ascontiguousarray(lab.T) if lab_c is None else lab_c
    lo = lab_c.min(axis=1)
    idx = np.floor((lab_c - lo[:, None]) / bin_size).astype(np.int64)
    shape = tuple(int(s) for s in idx.max(axis=1) + 1)
    counts = np.bincount(np.ravel_multi_index(tuple(idx), shape), minlength=int(np.prod(shape)))
    counts = counts.astype(np.float64).reshape(shape)
    density = box_mean3(counts)
    peak = np.array(np.unravel_index(int(np.argmax(density)), shape))
    near = np.all(np.abs(idx - peak[:, None]) <= 1, axis=0)
    return lab[near].mean(axis=0)  # over the (N, 3) rows: the sums in the same order


def _inner_box(box_px: np.ndarray, margin: float, rows: tuple[float, float]) -> tuple[int, int, int, int]:
    x0, y0, x1, y1 = (float(v) for v in box_px)
    w, h = x1 - x0, y1 - y0
    top, bottom = max(margin, rows[0]), min(1.0 - margin, rows[1])
    return round(x0 + w * margin), round(y0 + h * top), round(x1 - w * margin), round(y0 + h * bottom)


def nearer_cutting_boxes(
    boxes_px: np.ndarray, depths_m: np.ndarray, i: int, window: tuple[int, int, int, int]
) -> np.ndarray:
    """The boxes nearer than object ``i`` that cover at least one pixel of a window.

    These are exactly the occluders whose pixels :func:`object_colours` clears from a
    box-only object's region: every other nearer box's slice of the window is empty, so
    leaving them out changes nothing (and makes a crowd of N boxes cost less than N^2 slices).

    Args:
        boxes_px: (N, 4) int64 boxes ``xmin, ymin, xmax, ymax`` (max exclusive).
        depths_m: (N,) float64 depths; smaller is nearer.
        i: the object whose region is being cut.
        window: ``(x0, y0, x1, y1)`` the object's box clipped to the image, x1 > x0, y1 > y0.

    Returns:
        (K, 4) int64 rows of ``boxes_px``, in input order.
    """
    x0, y0, x1, y1 = window
    b = boxes_px
    cuts = (
        (depths_m < depths_m[i])
        & (b[:, 0] < b[:, 2])
        & (b[:, 1] < b[:, 3])
        & (b[:, 0] < x1)
        & (b[:, 2] > x0)
        & (b[:, 1] < y1)
        & (b[:, 3] > y0)
    )
    return b[cuts]


def object_colours(
    rgb: np.ndarray,
    boxes_px: np.ndarray,
    masks: Sequence[np.ndarray | None],
    depths_m: np.ndarray,
    params: PerceptionParams = DEFAULT_PERCEPTION,
    rows: Sequence[tuple[float, float]] | None = None,
) -> dict[int, MeasuredColour]:
    """Each object's colour from its own pixels (module docstring).

    Args:
        rgb: (H, W, 3) uint8 sRGB photo; only the pixels measured are decoded to linear RGB.
        boxes_px: (N, 4) int boxes ``xmin, ymin, xmax, ymax`` (max exclusive).
        masks: per object its (ymax-ymin, xmax-xmin) bool mask crop, or None for a box-only
            object (its region is then the box minus the boxes of nearer objects).
        depths_m: (N,) float depth of each object; smaller is nearer.
        params: ``colour_*`` fields.
        rows: per object the band of its box height (top, bottom fractions from the top) where
            its body colour is (a car's below its windows); default the whole height.

    Returns:
        Object index -> colour, for the objects with at least ``colour_min_pixels`` pixels.
    """
    h, w = rgb.shape[:2]
    boxes = np.asarray(boxes_px, dtype=np.int64).reshape(-1, 4)
    depths = np.asarray(depths_m, dtype=np.float64)
    out: dict[int, MeasuredColour] = {}
    for i, box in enumerate(boxes):
        x0, y0, x1, y1 = (int(v) for v in box)
        x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
        if x1 <= x0 or y1 <= y0:
            continue
        mask = masks[i]
        if mask is not None:
            region = np.zeros((y1 - y0, x1 - x0), dtype=bool)
            m = np.asarray(mask, dtype=bool)
            oy, ox = y0 - int(box[1]), x0 - int(box[0])
            region[:] = m[oy : oy + y1 - y0, ox : ox + x1 - x0]
            kind = "mask"
        else:
            region = np.ones((y1 - y0, x1 - x0), dtype=bool)
            for a0, b0, a1, b1 in nearer_cutting_boxes(boxes, depths, i, (x0, y0, x1, y1)).tolist():
                region[max(b0 - y0, 0) : max(b1 - y0, 0), max(a0 - x0, 0) : max(a1 - x0, 0)] = False
            kind = "box"
        ix0, iy0, ix1, iy1 = _inner_box(
            box, params.colour_inner_margin, rows[i] if rows is not None else (0.0, 1.0)
        )
        inner = np.zeros_like(region)
        inner[max(iy0 - y0, 0) : max(iy1 - y0, 0), max(ix0 - x0, 0) : max(ix1 - x0, 0)] = True
        if np.count_nonzero(region & inner) >= params.colour_min_pixels:
            region = region & inner
        if np.count_nonzero(region) < params.colour_min_pixels:
            continue
        pixels = sampled_pixels(rgb[y0:y1, x0:x1], region, params.colour_max_samples)
        out[i] = trimmed_colour(uint8_to_linear(pixels), kind, params)
    return out


def region_colour(
    rgb: np.ndarray, region: np.ndarray, kind: str, params: PerceptionParams = DEFAULT_PERCEPTION
) -> MeasuredColour | None:
    """The colour of an image region (road, sidewalk), or None when it has too few pixels.

    Args:
        rgb: (H, W, 3) uint8 sRGB photo; only the pixels measured are decoded to linear RGB.
        region: (H, W) bool pixels of the region.
        kind: what the region is (``labels``, ``inferred`` or ``ground``, see :data:`REGIONS`).
        params: ``colour_*`` fields.
    """
    count = np.count_nonzero(region)
    if count < params.colour_min_pixels:
        return None
    step = max(int(np.sqrt(count / params.colour_max_samples)), 1)  # a regular grid, not the whole image
    sub = region[::step, ::step]
    if np.count_nonzero(sub) < params.colour_min_pixels:
        sub, step = region, 1
    return trimmed_colour(uint8_to_linear(rgb[::step, ::step][sub]), kind, params)
