"""The street's stuff inferred from the photo when no segmentation is given.

With detection boxes alone a world would be cars on a plain: no road, sidewalk or
buildings. :func:`infer_street_labels` makes a Cityscapes labelIds-style map from the photo,
the detected things and the horizon, so that the code made for labels (facades, ground
surfaces, street lines) uses it unchanged:

* **road**: the ground below the horizon whose colour and texture match the pixels under
  the vehicles' contacts (a vehicle stands on the road), grown in CIELAB from them. The
  lightness difference counts half as much as the chroma (CMC l:c = 2:1), so the road in a
  building's shadow is still road; the growth stops at long straight edges that run to the
  street's vanishing point (kerbs, the road's edge), and the road's holes (lane markings,
  manhole covers) are filled;
* **sidewalk**: the band beside the road out to a sidewalk's usual width, measured on the
  ground (a pixel at row ``v`` below the horizon ``v_h`` lies ``X = (u - c_x) h / (v - v_h)``
  to the side of a camera ``h`` above the ground), stopped by the same long edges;
* **sky**: the bright, smooth region reaching the top of the image;
* **vegetation**: green by the excess-green-minus-excess-red index (Meyer and Neto 2008) of
  the photo white-balanced on the road (roads are grey), textured, above the ground;
* **building**: what is left above the ground: the vertical faces where the ground ends,
  up to the sky.

Pixels inside the things' boxes stay unlabelled (0): the boxes place the things.

Frames: image pixels (u right, v down). Thresholds: the ``streets_*`` fields of
:class:`~usdworld.parameters.PerceptionParams`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from usdworld.errors import LayoutError
from usdworld.parameters.perception import DEFAULT_PERCEPTION, PerceptionParams
from usdworld.perception.colour_space import linear_to_lab, uint8_to_linear
from usdworld.perception.facades import StreetView

#: Cityscapes label ids written into the inferred map.
ROAD_ID, SIDEWALK_ID, BUILDING_ID, VEGETATION_ID, SKY_ID = 7, 8, 11, 21, 23


class NoStreetError(LayoutError):
    """Nothing in the photo could be taken for a road (no vehicle contacts below the horizon
    and no road-like ground under the camera)."""


@dataclass(frozen=True)
class StreetBox:
    """A detected thing as the street inference needs it.

    Attributes:
        box_px: (4,) float64 ``xmin, ymin, xmax, ymax``, pixels (max edges exclusive).
        on_road: the thing drives on the road (a vehicle): the pixels under its contact are road.
    """

    box_px: np.ndarray
    on_road: bool


@dataclass(frozen=True)
class StreetLabels:
    """The inferred stuff map.

    Attributes:
        label_ids: (H, W) uint8 Cityscapes label ids (0 where nothing was inferred).
        seed: where the road's colour was taken: ``vehicles`` (under their contacts) or
            ``camera`` (the ground just ahead of the camera, at the bottom of the image).
        seed_pixels: how many pixels gave the road's colour.
    """

    label_ids: np.ndarray
    seed: str
    seed_pixels: int


def excess_green_red(rgb: np.ndarray, grey: np.ndarray, window: int) -> np.ndarray:
    """The excess-green-minus-excess-red vegetation index (Meyer and Neto 2008) of a photo white-balanced
    on a grey reference, less the index of grey, averaged over a window.

    ``ExG - ExR = (2g - r - b) - (1.4r - g)`` on chromatic coordinates ``r, g, b`` (each channel over
    their sum); grey scores ``-0.4 / 3``, so the result is 0 for grey and positive for green.

    Args:
        rgb: (H, W, 3) uint8 sRGB photo.
        grey: (3,) sRGB of something grey in it (the road).
        window: odd side of the averaging window, pixels.

    Returns:
        (H, W) float64.
    """
    x = rgb.astype(np.float64) / np.maximum(np.asarray(grey, dtype=np.float64), 1.0)
    s = x.sum(axis=-1) + 1e-9
    r, g, b = (x[..., k] / s for k in range(3))
    index = (2 * g - r - b) - (1.4 * r - g) + 0.4 / 3.0
    return cv2.blur(index, (window, window))


def _odd(n: float) -> int:
    k = max(3, int(round(n)))
    return k if k % 2 else k + 1


def local_std(channel: np.ndarray, window: int) -> np.ndarray:
    """Standard deviation of ``channel`` over a ``window`` x ``window`` neighbourhood.

    Args:
        channel: (H, W) float64.
        window: odd side length, pixels.

    Returns:
        (H, W) float64.
    """
    mean = cv2.blur(channel, (window, window))
    sq = cv2.blur(channel * channel, (window, window))
    return np.sqrt(np.maximum(sq - mean * mean, 0.0))


def _box_mask(shape: tuple[int, int], boxes: Sequence[StreetBox]) -> np.ndarray:
    h, w = shape
    mask = np.zeros(shape, dtype=bool)
    for b in boxes:
        x0, y0, x1, y1 = np.clip(np.round(b.box_px).astype(int), 0, [w, h, w, h])
        mask[y0:y1, x0:x1] = True
    return mask


def road_seeds(shape: tuple[int, int], boxes: Sequence[StreetBox], horizon_v: float, params: PerceptionParams) -> np.ndarray:
    """Pixels just under the vehicles' contacts: the road they stand on.

    Args:
        shape: (H, W) of the image.
        boxes: the detected things; only those ``on_road`` whose bottom is below the horizon and
            above the image's last row seed.
        horizon_v: the horizon's row.
        params: ``streets_seed_band`` and ``streets_seed_inset``.

    Returns:
        (H, W) bool, outside every box.
    """
    h, w = shape
    seeds = np.zeros(shape, dtype=bool)
    for b in boxes:
        x0, y0, x1, y1 = (float(x) for x in b.box_px)
        if not b.on_road or y1 <= horizon_v or y1 >= h:
            continue
        inset = params.streets_seed_inset * (x1 - x0)
        depth = max(params.streets_seed_band * (y1 - y0), 2.0)
        u0, u1 = int(np.clip(round(x0 + inset), 0, w)), int(np.clip(round(x1 - inset), 0, w))
        v0, v1 = int(np.clip(round(y1), 0, h)), int(np.clip(round(y1 + depth), 0, h))
        seeds[v0:v1, u0:u1] = True
    return seeds & ~_box_mask(shape, boxes)


def street_edges(lab_l: np.ndarray, view: StreetView, params: PerceptionParams) -> np.ndarray:
    """Long straight edges below the horizon that run to the street's vanishing point (kerbs, road edges).

    Without a vanishing point, every long edge below the horizon that is not near horizontal counts.

    Args:
        lab_l: (H, W) float64 CIELAB lightness of the photo.
        view: the horizon row and the vanishing point's column.
        params: ``streets_edge_min_length`` and ``streets_edge_angle_tol``.

    Returns:
        (H, W) bool, the segments (LSD) drawn one pixel wide.
    """
    h, w = lab_l.shape
    img = np.clip(lab_l * 2.55, 0, 255).astype(np.uint8)
    lsd = cv2.createLineSegmentDetector(cv2.LSD_REFINE_STD)
    found = lsd.detect(img)[0]
    out = np.zeros((h, w), dtype=np.uint8)
    if found is None:
        return out.astype(bool)
    seg = found.reshape(-1, 4).astype(np.float64)
    min_len = params.streets_edge_min_length * w
    for x0, y0, x1, y1 in seg:
        if max(y0, y1) <= view.horizon_v or np.hypot(x1 - x0, y1 - y0) < min_len:
            continue
        d = np.array([x1 - x0, y1 - y0])
        d /= np.linalg.norm(d)
        if view.vanishing_u is not None:
            mid = np.array([(x0 + x1) / 2, (y0 + y1) / 2])
            to_vp = np.array([view.vanishing_u, view.horizon_v]) - mid
            to_vp /= max(np.linalg.norm(to_vp), 1e-9)
            if abs(float(d @ to_vp)) < np.cos(params.streets_edge_angle_tol):
                continue
        elif abs(d[1]) < np.sin(params.streets_edge_angle_tol):
            continue
        cv2.line(out, (int(round(x0)), int(round(y0))), (int(round(x1)), int(round(y1))), 1, 1)
    return out.astype(bool)


def _fill_holes(mask: np.ndarray) -> np.ndarray:
    """The mask with its enclosed holes filled (a hole touching the border stays open)."""
    inv = (~mask).astype(np.uint8)
    n, lab = cv2.connectedComponents(inv, connectivity=4)
    border = np.unique(np.concatenate([lab[0], lab[-1], lab[:, 0], lab[:, -1]]))
    holes = ~np.isin(lab, border) & (lab > 0)
    return mask | holes


def _grow(candidate: np.ndarray, seeds: np.ndarray) -> np.ndarray:
    """The connected parts of ``candidate`` (4-connected) that hold a seed."""
    n, lab = cv2.connectedComponents(candidate.astype(np.uint8), connectivity=4)
    keep = np.unique(lab[seeds & candidate])
    keep = keep[keep > 0]
    return np.isin(lab, keep)


def infer_street_labels(
    rgb: np.ndarray,
    boxes: Sequence[StreetBox],
    view: StreetView,
    params: PerceptionParams = DEFAULT_PERCEPTION,
) -> StreetLabels:
    """Road, sidewalk, building, vegetation and sky of a street photo, from its colours and geometry.

    Args:
        rgb: (H, W, 3) uint8 sRGB photo.
        boxes: the detected things (vehicles seed the road; every box is left unlabelled).
        view: the horizon row, focal length, principal point, camera height and, when the
            photo's lines give one, the street's vanishing point's column.
        params: the ``streets_*`` thresholds.

    Returns:
        The inferred map.

    Raises:
        NoStreetError: no road could be found (see the class).
    """
    h, w = rgb.shape[:2]
    lab = linear_to_lab(uint8_to_linear(rgb))
    window = _odd(params.streets_texture_window * w)
    texture = local_std(lab[..., 0], window)
    vh = float(view.horizon_v)
    rows = np.arange(h, dtype=np.float64)[:, None] * np.ones((1, w))
    below = rows > vh + params.streets_horizon_margin * h
    boxed = _box_mask((h, w), boxes)

    edges = street_edges(lab[..., 0], view, params)
    found = []
    for seed_kind, seeds in (
        ("vehicles", road_seeds((h, w), boxes, vh, params) & below),
        ("camera", _camera_seeds((h, w), params) & below & ~boxed),
    ):
        if seeds.sum() < params.streets_min_seed_px:
            found.append(f"{seed_kind}: {int(seeds.sum())} seed pixels")
            continue
        road = _road(lab, texture, seeds, below & ~boxed, edges, w, params)
        if road.sum() >= params.streets_min_road_fraction * h * w:
            break
        found.append(f"{seed_kind}: road-like ground of {int(road.sum())} pixels")
    else:
        raise NoStreetError(
            f"no road below the horizon (at least {params.streets_min_road_fraction:.1%} of the image, grown from "
            f"under the vehicles, else from just ahead of the camera): {'; '.join(found)}"
        )

    labels = np.zeros((h, w), dtype=np.uint8)
    labels[road] = ROAD_ID
    sidewalk = _sidewalk(road, below & ~boxed & ~road, edges, vh, view, params)
    labels[sidewalk] = SIDEWALK_ID

    ground = road | sidewalk
    sky = _sky(lab, texture, rows < vh, params)
    labels[sky & ~ground & ~boxed] = SKY_ID
    # Above the ground: the lowest ground pixel of each column bounds what stands on it.
    has_ground = ground.any(axis=0)
    lowest = np.where(has_ground, h - 1 - np.argmax(ground[::-1], axis=0), -1)
    above = (rows <= lowest[None, :]) | (rows < vh)
    rest = above & ~ground & ~sky & ~boxed
    # The road is grey: its colour is the photo's neutral (white balance and tint included).
    green = (excess_green_red(rgb, np.median(rgb[seeds], axis=0), _odd(3 * window)) > params.streets_excess_green) & (
        texture > params.streets_vegetation_texture
    )
    green = cv2.morphologyEx(green.astype(np.uint8), cv2.MORPH_OPEN, np.ones((window, window), np.uint8)).astype(bool)
    labels[rest & green] = VEGETATION_ID
    labels[rest & ~green] = BUILDING_ID
    return StreetLabels(labels, seed_kind, int(seeds.sum()))


def _camera_seeds(shape: tuple[int, int], params: PerceptionParams) -> np.ndarray:
    """(H, W) bool the bottom rows of the middle third: the ground just ahead of the camera, which stands on the road."""
    h, w = shape
    seeds = np.zeros(shape, dtype=bool)
    v0 = int(round(h * (1.0 - params.streets_camera_seed_rows)))
    seeds[max(v0, 0) :, int(round(w / 3)) : int(round(2 * w / 3))] = True
    return seeds


def _road(
    lab: np.ndarray,
    texture: np.ndarray,
    seeds: np.ndarray,
    free: np.ndarray,
    edges: np.ndarray,
    width: int,
    params: PerceptionParams,
) -> np.ndarray:
    """(H, W) bool the free ground grown from ``seeds`` through pixels of their colour and texture.

    The colour difference weighs lightness by ``1 / streets_lightness_weight``; the growth stops at
    ``edges``; the road is closed (lane markings), its holes filled, and every free pixel between it
    and the image bottom joined (the camera stands on the road).
    """
    ref = np.median(lab[seeds], axis=0)
    diff = lab - ref
    dist = np.sqrt((diff[..., 0] / params.streets_lightness_weight) ** 2 + diff[..., 1] ** 2 + diff[..., 2] ** 2)
    seed_tex = float(np.median(texture[seeds]))
    candidate = (
        free
        & ~edges
        & (dist < params.streets_colour_tolerance)
        & (texture < max(params.streets_texture_max, params.streets_texture_factor * seed_tex))
    )
    road = _grow(candidate, seeds)
    k = _odd(params.streets_close_window * width)
    road = cv2.morphologyEx(road.astype(np.uint8), cv2.MORPH_CLOSE, np.ones((k, k), np.uint8)).astype(bool)
    return _fill_holes(road | _below_road(road, free)) & free


def _sidewalk(
    road: np.ndarray, free: np.ndarray, edges: np.ndarray, vh: float, view: StreetView, params: PerceptionParams
) -> np.ndarray:
    """(H, W) bool the band beside the road, out to ``streets_sidewalk_width_m`` on the ground."""
    h, w = road.shape
    out = np.zeros((h, w), dtype=bool)
    u = np.arange(w, dtype=np.float64)
    for v in range(h):
        if v <= vh or not road[v].any():
            continue
        scale = view.camera_height_m / (v - vh)  # metres per pixel across, on the ground at this row
        x = (u - view.principal_u) * scale
        cols = np.nonzero(road[v])[0]
        left, right = cols[0], cols[-1]
        band = ((x < x[left]) & (x >= x[left] - params.streets_sidewalk_width_m)) | (
            (x > x[right]) & (x <= x[right] + params.streets_sidewalk_width_m)
        )
        out[v] = band & free[v]
    # Stop at the next long street edge beyond the kerb: keep what connects to the road's side.
    # (the kerb itself, a dark line with an edge on either side, is crossed: the road grown by three
    # pixels seeds it).
    return _grow(out & ~edges, cv2.dilate(road.astype(np.uint8), np.ones((7, 7), np.uint8)).astype(bool))


def _below_road(road: np.ndarray, free: np.ndarray) -> np.ndarray:
    """(H, W) bool the free pixels between each column's road and the image bottom, down to the first
    non-free pixel: the camera stands on the road, so the ground between a road pixel and the camera is
    road unless a kerb's edge (or a box) comes between."""
    h, w = road.shape
    out = np.zeros_like(road)
    for u in range(w):
        col = np.nonzero(road[:, u])[0]
        if not len(col):
            continue
        blocked = np.nonzero(~free[col[-1] + 1 :, u])[0]
        stop = col[-1] + 1 + (blocked[0] if len(blocked) else h)
        out[col[-1] + 1 : stop, u] = True
    return out


def _sky(lab: np.ndarray, texture: np.ndarray, upper: np.ndarray, params: PerceptionParams) -> np.ndarray:
    """(H, W) bool the bright, smooth region above the horizon that reaches the top row."""
    candidate = upper & (lab[..., 0] > params.streets_sky_lightness) & (texture < params.streets_sky_texture)
    top = np.zeros_like(candidate)
    top[0] = True
    return _grow(candidate, top)
