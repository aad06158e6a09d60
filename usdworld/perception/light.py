"""The sun and the sky from the photo: cast shadows at the objects' feet, and the sky's pixels.

Every placed object stands on the ground and, in sunshine, casts a shadow there: its
footprint swept away from the sun by ``height / tan(elevation)`` (exact for a prism on
flat ground: the shadow is the convex hull of the footprint and the footprint moved along
the shadow direction). Ground samples in a ring around each footprint are projected into
the photo with the ground homography; a sample counts as shadowed when its pixel is
darker than the lit ground of its own surface (road, sidewalk, terrain) by
``sunny_min_contrast``; a surface's lit luminance is a percentile of its pixels, read on
every k-th row and column of a photo ``k`` times ``reference_width_px`` wide (each sample
reads its own pixel). The sun's azimuth and elevation are the ones whose predicted
shadows (the union over all casters) overlap the shadowed samples best (intersection over
union, a coarse grid and then one degree; each pair of a sample and a caster needs one
test per azimuth: the shortest shadow of the caster that covers the sample). Samples
hidden in the photo (under another object, or not ground) are left out, so a shadow
hidden behind its own caster costs nothing.
An object whose top is out of view has a height known only between a least and a most
(what the photo shows of it, its class's tallest): its shadow is sure up to the shorter of
the two shadows, and the ground between the two counts neither way (unless another
caster's shadow surely covers it), so its placed height (a prior's) pulls no sun.
The trust gate below reads the overlap of the sure shadows alone with the observed ones:
shadowed ground in that band counts against the fit there, so hiding it earns no trust.

Sunny or overcast: direct sun makes a lit surface 3 to 10 times brighter than one in
shadow; under an overcast sky nothing casts a shadow, so the share of shadowed samples
around the casters (each caster's ring weighing the same) decides; the fit runs only
for a sunny photo. A fit that explains little is not trusted: when its predicted and
observed shadows overlap less than two equal shadows shifted by half their area do (IoU
``min_fit_iou``) or its predicted shadows meet shadowed ground next to fewer than
``min_fit_casters`` casters (one caster's shadow is one direction and one length, easily
mimicked by a shadow of something unseen), the method is ``weak_fit`` and the sun is the
caller's default.

The sky's colour: the median linear RGB of the top and the bottom rows of its pixels
(the sky labels when given, else the smooth bright part of the image above the horizon).

Everything is in pixel and ground coordinates; nothing here reads files or knows about USD.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from usdworld.parameters.light import LightParams
from usdworld.perception.colour_space import uint8_to_linear

#: Rec. 709 luminance weights of linear RGB.
LUMA = np.array([0.2126, 0.7152, 0.0722])

#: How the sun was found: cast shadows fitted, a fit too weak to trust (the default sun),
#: overcast (no shadows), or no evidence at all.
METHODS = ("cast_shadows", "weak_fit", "overcast", "no_evidence")


@dataclass(frozen=True)
class ShadowCaster:
    """An object standing on the ground, as the light estimate sees it.

    Attributes:
        name: the placed object's name (for reports).
        footprint_ground: (N, 2) float64 corners of its convex footprint on the ground, metres.
        height_m: its height above the ground, metres (> 0); for an object whose top is not
            seen, the least height it can have (what the photo shows of it).
        height_max_m: for an object whose top is not seen (cut by the image's top), the
            most it can be, metres (>= ``height_m``); None when its height is known.
    """

    name: str
    footprint_ground: np.ndarray
    height_m: float
    height_max_m: float | None = None

    def __post_init__(self) -> None:
        f = np.array(self.footprint_ground, dtype=np.float64)
        if f.ndim != 2 or f.shape[1] != 2 or len(f) < 1 or not np.all(np.isfinite(f)):
            raise ValueError(f"ShadowCaster.footprint_ground: (N, 2) finite, got shape {f.shape}")
        if not (math.isfinite(self.height_m) and self.height_m > 0):
            raise ValueError(f"ShadowCaster.height_m: must be > 0, got {self.height_m}")
        if self.height_max_m is not None and not (
            math.isfinite(self.height_max_m) and self.height_max_m >= self.height_m
        ):
            raise ValueError(
                f"ShadowCaster.height_max_m: must be >= height_m ({self.height_m}), got {self.height_max_m}"
            )
        f.setflags(write=False)
        object.__setattr__(self, "footprint_ground", f)

    @property
    def tallest_m(self) -> float:
        """The most the object can be high, metres (its height when known)."""
        return self.height_m if self.height_max_m is None else float(self.height_max_m)


@dataclass(frozen=True)
class LightEstimate:
    """The sun and sky found in a photo.

    Attributes:
        method: ``cast_shadows`` (the sun fitted to shadows), ``weak_fit`` (a fit that
            explains too little; the sun is the caller's default), ``overcast`` (too few
            shadowed samples around the casters) or ``no_evidence`` (no caster with visible
            ground around it; the sun is the caller's default).
        overcast: True when the photo shows no direct sun.
        sun_azimuth: radians from world +X towards +Y of the direction towards the sun
            (meaningful only for ``cast_shadows``; the default otherwise).
        sun_elevation: radians above the horizon (as above).
        shadow_contrast: lit ground luminance over the median of the shadowed samples' (1
            when none is shadowed, NaN when unmeasured).
        shadow_share: share of the ground samples around the casters that is shadowed (each
            caster's ring weighing the same; NaN when unmeasured).
        fit_iou: overlap of the surely predicted and the observed shadows at the fit (the
            ground a top-cut caster's shadow may or may not reach counts as not predicted;
            NaN unless fitted; ``weak_fit`` keeps the weak fit's).
        casters: how many casters had visible ground around them.
        shadow_samples: ground samples inside the fitted shadows (0 unless fitted).
        fit_casters: casters whose shadow at the fit meets shadowed ground (0 unless fitted).
        sky_zenith_linear: (3,) float64 linear RGB of the top of the sky (NaN when no sky is seen).
        sky_horizon_linear: (3,) float64 linear RGB of the sky near the horizon (NaN when none).
        sky_source: ``labels``, ``image`` (the bright smooth region above the horizon) or ``none``.
    """

    method: str
    overcast: bool
    sun_azimuth: float
    sun_elevation: float
    shadow_contrast: float
    shadow_share: float
    fit_iou: float
    casters: int
    shadow_samples: int
    fit_casters: int
    sky_zenith_linear: np.ndarray
    sky_horizon_linear: np.ndarray
    sky_source: str

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"LightEstimate.method: one of {METHODS}, got {self.method!r}")
        if not 0.0 < self.sun_elevation < math.pi / 2:
            raise ValueError(f"LightEstimate.sun_elevation: in (0, pi/2), got {self.sun_elevation}")
        for name in ("sky_zenith_linear", "sky_horizon_linear"):
            a = np.array(getattr(self, name), dtype=np.float64)
            if a.shape != (3,):
                raise ValueError(f"LightEstimate.{name}: 3 numbers, got shape {a.shape}")
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    @property
    def sun_direction_world(self) -> np.ndarray:
        """(3,) float64 unit vector towards the sun."""
        az, el = self.sun_azimuth, self.sun_elevation
        return np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])


def luminance(rgb: np.ndarray) -> np.ndarray:
    """(H, W) float64 linear luminance of an (H, W, 3) uint8 sRGB image."""
    return uint8_to_linear(rgb) @ LUMA


def present_ids(ids: np.ndarray) -> np.ndarray:
    """(M,) int the distinct values of an integer array, ascending (as ``np.unique``).

    A histogram when the values are small non-negative ids (no sort), else ``np.unique``.

    Args:
        ids: (...) int array.
    """
    ids = np.asarray(ids)
    if ids.size == 0 or ids.min() < 0:
        return np.unique(ids)
    top = int(ids.max())
    if top < 256:  # OpenCV's histogram of 8-bit values, one pass
        hist = cv2.calcHist([np.ascontiguousarray(ids, dtype=np.uint8).reshape(-1, 1)], [0], None, [256], [0, 256])
        return np.flatnonzero(hist.ravel())
    if top < 1 << 16:
        return np.flatnonzero(np.bincount(ids.ravel()))
    return np.unique(ids)


def inner_ground(ground_ids: np.ndarray, edge_px: int) -> np.ndarray:
    """(H, W) int32 surface ids with ``edge_px`` pixels taken off every surface's outline.

    Pixels at a surface's edge mix it with what borders it (a kerb's face, an object's
    outline), so they say nothing about its light.

    Args:
        ground_ids: (H, W) int surface id per pixel, 0 where not ground.
        edge_px: pixels taken off (0: none).
    """
    ids = np.asarray(ground_ids).astype(np.int32)
    if edge_px <= 0:
        return ids
    kernel = np.ones((2 * edge_px + 1, 2 * edge_px + 1), dtype=np.uint8)
    out = np.zeros_like(ids)
    for sid in present_ids(ids):
        if sid == 0:
            continue
        inner = cv2.erode((ids == sid).view(np.uint8), kernel, borderType=cv2.BORDER_REPLICATE).view(bool)
        out[inner] = sid
    return out


def inner_ids_at(ground_ids: np.ndarray, v: np.ndarray, u: np.ndarray, edge_px: int) -> np.ndarray:
    """(N,) int64 :func:`inner_ground`'s surface ids at some pixels, without eroding the whole image.

    A pixel keeps its surface's id when every pixel within ``edge_px`` of it (the image's
    border repeated outwards) has the same id: what eroding the surface's mask by the square
    kernel gives there.

    Args:
        ground_ids: (H, W) int surface id per pixel, 0 where not ground.
        v: (N,) int rows inside the image.
        u: (N,) int columns inside the image.
        edge_px: pixels taken off every surface's outline (0: none).
    """
    h, w = ground_ids.shape
    sid = ground_ids[v, u].astype(np.int64)
    keep = np.ones(len(sid), dtype=bool)
    cols = [np.clip(u + du, 0, w - 1) for du in range(-edge_px, edge_px + 1)]
    for dv in range(-edge_px, edge_px + 1):
        rows = np.clip(v + dv, 0, h - 1)
        for du, col in zip(range(-edge_px, edge_px + 1), cols):
            if dv or du:
                keep &= ground_ids[rows, col] == sid
    return np.where(keep, sid, 0)


def reference_stride(width: int, reference_width_px: int) -> int:
    """Every how many rows and columns the lit references are read: ``width // reference_width_px`` (>= 1)."""
    return max(1, width // reference_width_px)


def lit_references(lum: np.ndarray, ground_ids: np.ndarray, percentile: float) -> dict[int, float]:
    """The lit luminance of each ground surface.

    Args:
        lum: (H, W) float64 linear luminance.
        ground_ids: (H, W) int surface id per pixel, 0 where not ground.
        percentile: the percentile of a surface's pixels taken as lit.

    Returns:
        surface id -> lit luminance (surfaces with a positive one only).
    """
    refs = {}
    for sid in present_ids(ground_ids):
        if sid == 0:
            continue
        ref = float(np.percentile(lum[ground_ids == sid], percentile))
        if ref > 0:
            refs[int(sid)] = ref
    return refs


def _hull(points: np.ndarray) -> np.ndarray:
    """(M, 2) counter-clockwise convex hull of (N, 2) points (monotone chain)."""
    pts = sorted(map(tuple, np.round(points, 9)))
    if len(pts) <= 2:
        return np.array(pts, dtype=np.float64)

    def half(seq: list) -> list:
        out: list = []
        for p in seq:
            while len(out) >= 2 and (
                (out[-1][0] - out[-2][0]) * (p[1] - out[-2][1]) - (out[-1][1] - out[-2][1]) * (p[0] - out[-2][0])
            ) <= 0:
                out.pop()
            out.append(p)
        return out

    lower, upper = half(pts), half(pts[::-1])
    return np.array(lower[:-1] + upper[:-1], dtype=np.float64)


def inside_convex(points: np.ndarray, hull: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """(N,) bool: the points within ``margin`` metres inside a counter-clockwise convex polygon.

    Args:
        points: (N, 2) float64.
        hull: (M, 2) float64 counter-clockwise vertices, M >= 3 (fewer: a segment or a
            point, grown by ``margin``).
        margin: grows the polygon by this distance along each edge's normal.
    """
    if len(hull) < 3:
        if len(hull) == 1:
            return np.linalg.norm(points - hull[0], axis=1) <= margin
        a, b = hull[0], hull[-1]
        ab = b - a
        t = np.clip(((points - a) @ ab) / max(float(ab @ ab), 1e-12), 0.0, 1.0)
        return np.linalg.norm(points - (a + t[:, None] * ab), axis=1) <= margin
    return ConvexEdges.of(hull).inside(points, margin)


@dataclass(frozen=True)
class ConvexEdges:
    """A counter-clockwise convex polygon's edges of non-zero length, for many :func:`inside_convex` tests.

    Attributes:
        edges: (K, 2) float64 edge vectors.
        starts: (K, 2) float64 their start vertices.
        lengths: (K,) float64 their lengths.
    """

    edges: np.ndarray
    starts: np.ndarray
    lengths: np.ndarray

    @staticmethod
    def of(hull: np.ndarray) -> ConvexEdges:
        """The edges of a hull of M >= 3 vertices."""
        edges = np.roll(hull, -1, axis=0) - hull
        lengths = np.linalg.norm(edges, axis=1)
        keep = lengths > 1e-12
        return ConvexEdges(edges[keep], hull[keep], lengths[keep])

    def inside(self, points: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """(N,) bool: the (N, 2) points within ``margin`` metres inside (:func:`inside_convex`).

        Edge by edge on the points' two columns: the same products and differences as the
        (N, K, 2) broadcast, without its temporaries (a footprint has a few edges).
        """
        u, v = points[:, 0], points[:, 1]
        out = np.ones(len(points), dtype=bool)
        edges = zip(self.edges.tolist(), self.starts.tolist(), self.lengths.tolist())
        for (ex, ey), (sx, sy), length in edges:
            out &= ex * (v - sy) - ey * (u - sx) >= -margin * length
        return out


def _grown_reach(hull: np.ndarray, margin: float) -> float:
    """How far :func:`inside_convex`'s polygon grown by ``margin`` reaches beyond ``hull``'s vertices, metres.

    Each edge moves out by ``margin``, so a corner of interior angle ``t`` moves by
    ``margin / sin(t / 2)``; a hull of fewer than 3 vertices grows by ``margin`` (a disc
    round a point or a capsule round a segment).

    Args:
        hull: (M, 2) float64 counter-clockwise convex polygon.
        margin: the growth, metres (>= 0).
    """
    if len(hull) < 3 or margin == 0.0:
        return float(margin)
    edges = np.roll(hull, -1, axis=0) - hull
    edges = edges[np.linalg.norm(edges, axis=1) > 1e-12]
    if len(edges) < 3:
        return float(margin)
    before = np.roll(edges, 1, axis=0)
    turn = np.arctan2(before[:, 0] * edges[:, 1] - before[:, 1] * edges[:, 0], np.einsum("ij,ij->i", before, edges))
    half_interior = (np.pi - np.abs(turn)) / 2.0
    return float(margin / max(float(np.sin(half_interior).min()), 1e-6)) * (1.0 + 1e-9)


@dataclass(frozen=True)
class _Samples:
    points_ground: np.ndarray  # (N, 2)
    relative: np.ndarray  # (N,) luminance / lit luminance of the surface
    neighbours: tuple[np.ndarray, ...]  # per caster: indices of samples within its reach


def _reach(caster: ShadowCaster, params: LightParams) -> float:
    return min(caster.tallest_m / math.tan(math.radians(params.elevation_range_deg[0])), params.reach_max_m)


def _ring_samples(
    casters: Sequence[ShadowCaster],
    rgb: np.ndarray,
    ground_ids: np.ndarray,
    refs: dict[int, float],
    ground_from_px: np.ndarray,
    params: LightParams,
) -> tuple[_Samples, list[int]]:
    """Visible ground samples around every caster, and the casters that have some.

    Each sample reads its own pixel: its surface (``edge_px`` inside the outline,
    :func:`inner_ids_at`) and its luminance over that surface's lit reference.
    """
    h, w = ground_ids.shape
    px_from_ground = np.linalg.inv(ground_from_px)
    bottom = ground_from_px @ np.array([w / 2.0, h - 0.5, 1.0])  # seen ground: in front of the camera
    if (px_from_ground @ bottom)[2] * bottom[2] < 0:  # a homography is defined up to sign
        px_from_ground = -px_from_ground
    pts_all, rel_all = [], []
    used = []
    lit = np.zeros(max(refs, default=0) + 1)  # surface id -> its lit luminance (0: no reference)
    lit[list(refs)] = list(refs.values())
    footprints = [_hull(c.footprint_ground) for c in casters]

    def inside(points: np.ndarray, j: int, margin: float) -> np.ndarray:
        """:func:`inside_convex` of footprint ``j``, its edges found once."""
        if len(footprints[j]) < 3:
            return inside_convex(points, footprints[j], margin)
        if j not in edges:
            edges[j] = ConvexEdges.of(footprints[j])
        return edges[j].inside(points, margin)

    edges: dict[int, ConvexEdges] = {}
    # Each footprint grown by the margin lies within its bounding box grown by ``grow``: only the
    # footprints whose grown box meets a caster's sampling square can hide any of its samples.
    grow = np.array([_grown_reach(f, params.footprint_margin_m) for f in footprints])
    boxes_lo = np.array([f.min(axis=0) for f in footprints]) - grow[:, None]
    boxes_hi = np.array([f.max(axis=0) for f in footprints]) + grow[:, None]
    for i, c in enumerate(casters):
        reach = _reach(c, params)
        lo = c.footprint_ground.min(axis=0) - reach
        hi = c.footprint_ground.max(axis=0) + reach
        n = params.samples_per_side
        gx, gy = np.meshgrid(np.linspace(lo[0], hi[0], n), np.linspace(lo[1], hi[1], n))
        pts = np.column_stack([gx.ravel(), gy.ravel()])
        near = inside(pts, i, reach)
        meets = np.flatnonzero(np.all(boxes_lo <= hi, axis=1) & np.all(boxes_hi >= lo, axis=1))
        for j in meets:  # ground under any footprint is not seen lit or shadowed
            near &= ~inside(pts, j, params.footprint_margin_m)
        pts = pts[near]
        if len(pts) == 0:
            continue
        homog = np.column_stack([pts, np.ones(len(pts))]) @ px_from_ground.T
        front = homog[:, 2] > 1e-9
        uv = np.full((len(pts), 2), -1.0)
        uv[front] = homog[front, :2] / homog[front, 2:3]
        u, v = np.floor(uv[:, 0]).astype(np.int64), np.floor(uv[:, 1]).astype(np.int64)
        ok = front & (u >= 0) & (u < w) & (v >= 0) & (v < h)
        sid = np.zeros(len(pts), dtype=np.int64)
        sid[ok] = inner_ids_at(ground_ids, v[ok], u[ok], params.edge_px)
        ok &= np.isin(sid, list(refs))
        if not np.any(ok):
            continue
        ref = lit[sid[ok]]
        pts_all.append(pts[ok])
        rel_all.append(luminance(rgb[v[ok], u[ok]]) / ref)
        used.append(i)
    if not pts_all:
        return _Samples(np.zeros((0, 2)), np.zeros(0), ()), []
    points = np.concatenate(pts_all)
    neighbours = []
    for i in used:
        c, reach = casters[i], _reach(casters[i], params)
        near = inside(points, i, reach) if len(footprints[i]) >= 3 else np.ones(len(points), bool)
        neighbours.append(np.flatnonzero(near))
    return _Samples(points, np.concatenate(rel_all), tuple(neighbours)), used


def half_planes(polygon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The half-planes ``a . x <= b`` whose intersection is a convex polygon.

    Args:
        polygon: (M, 2) float64 counter-clockwise vertices, M >= 3.

    Returns:
        (K, 2) outward normals ``a`` and (K,) offsets ``b`` (one per edge of non-zero length).
    """
    edges = np.roll(polygon, -1, axis=0) - polygon
    keep = np.linalg.norm(edges, axis=1) > 1e-12
    edges, starts = edges[keep], polygon[keep]
    normals = np.column_stack([edges[:, 1], -edges[:, 0]])  # right of a ccw edge: outwards
    return normals, np.einsum("ij,ij->i", normals, starts)


def sweep_entry(slack: np.ndarray, rate: np.ndarray) -> np.ndarray:
    """(P,) float64 how far each point's convex footprint must be swept to cover it (inf: never).

    A point ``p`` is in the footprint ``{x: a . x <= b}`` moved by ``t * v`` when
    ``a . p - b <= t * (a . v)`` for all the half-planes: the least ``t >= 0`` for which
    the bounds leave an interval, in multiples of ``v``.

    Args:
        slack: (P, K) float64 ``a . p - b`` per point and half-plane (<= 0: inside it).
        rate: (P, K) float64 ``a . v``, the sweep vector along each half-plane's normal.
    """
    # Half-plane by half-plane (K is a footprint's few edges): the same bounds, without (P, K) temporaries.
    lower = np.zeros(len(slack))
    upper = np.full(len(slack), np.inf)
    inside = np.ones(len(slack), dtype=bool)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for k in range(slack.shape[1]):
            s, r = slack[:, k], rate[:, k]
            rising, falling = r > 1e-12, r < -1e-12
            bound = s / r
            np.maximum(lower, np.where(rising, bound, -np.inf), out=lower)
            np.minimum(upper, np.where(falling, bound, np.inf), out=upper)
            inside &= rising | falling | ~(s > 0)  # a half-plane the sweep runs along: the point must be inside it
    return np.where((lower <= upper) & inside, lower, np.inf)


def in_swept(slack: np.ndarray, rate: np.ndarray) -> np.ndarray:
    """(P,) bool: each point lies in its convex footprint swept along a vector (by 0 to 1 of it).

    Args:
        slack: (P, K) float64 ``a . p - b`` per point and half-plane (<= 0: inside it).
        rate: (P, K) float64 ``a . v``, the sweep vector along each half-plane's normal.
    """
    return sweep_entry(slack, rate) <= 1.0


@dataclass(frozen=True)
class _Pairs:
    """Every (sample, caster) pair within the caster's reach, flattened for vectorised tests."""

    sample: np.ndarray  # (P,) sample index
    caster: np.ndarray  # (P,) caster index
    normals: np.ndarray  # (C, K, 2) each caster's footprint half-planes (padded with 0 . x <= 1)
    slack: np.ndarray  # (P, K) a . p - b
    height: np.ndarray  # (P,) the caster's height (the least it can be when its top is not seen), m
    height_max: np.ndarray  # (P,) the most the caster's height can be, m
    offset: np.ndarray  # (P, 2) the sample's position from the footprint's centre, m
    radius: np.ndarray  # (P,) the footprint's radius about that centre, m

    @functools.cached_property
    def margin(self) -> np.ndarray:
        """(P,) float64 the half-width of a caster's shadow strip, m: its radius and a hair."""
        return self.radius + 1e-9

    @functools.cached_property
    def slack_by_plane(self) -> np.ndarray:
        """(K, P) float64 ``slack`` half-plane by half-plane (each row contiguous)."""
        return np.ascontiguousarray(self.slack.T)


def _footprint_hull(caster: ShadowCaster) -> np.ndarray:
    """(M, 2) the footprint's convex hull; a footprint of fewer than 3 corners counts as a 10 cm square."""
    hull = _hull(caster.footprint_ground)
    if len(hull) < 3:
        hull = hull.mean(axis=0) + np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * 0.05
    return hull


def _pairs(casters: Sequence[ShadowCaster], samples: _Samples) -> _Pairs:
    hulls = [_footprint_hull(c) for c in casters]
    planes = [half_planes(h) for h in hulls]
    k = max(len(a) for a, _ in planes)
    normals, slack, height, height_max, offset, radius = [], [], [], [], [], []
    for c, hull, (a, b), near in zip(casters, hulls, planes, samples.neighbours, strict=True):
        # pad to k half-planes with always-true rows (0 . x <= 1)
        a = np.vstack([a, np.zeros((k - len(a), 2))])
        b = np.concatenate([b, np.ones(k - len(b))])
        normals.append(a)
        slack.append(samples.points_ground[near] @ a.T - b)
        height.append(np.full(len(near), c.height_m))
        height_max.append(np.full(len(near), c.tallest_m))
        centre = hull.mean(axis=0)
        offset.append(samples.points_ground[near] - centre)
        radius.append(np.full(len(near), float(np.max(np.linalg.norm(hull - centre, axis=1)))))
    return _Pairs(
        np.concatenate(samples.neighbours),
        np.concatenate([np.full(len(near), i) for i, near in enumerate(samples.neighbours)]),
        np.array(normals).reshape(len(casters), k, 2),
        np.concatenate(slack),
        np.concatenate(height),
        np.concatenate(height_max),
        np.concatenate(offset),
        np.concatenate(radius),
    )


@dataclass(frozen=True)
class _Strip:
    """The pairs that a sun at one azimuth can shadow at all, and the shadow length each needs.

    A caster's swept footprint lies inside its bounding disc swept along the shadow, a
    stadium: only the pairs inside that stadium's bounding strip (of any length) need the
    exact test. The test's bounds do not depend on the shadow's length, only the sweep's
    end does, so each pair's least shadow length that covers its sample is found once per
    azimuth and serves every elevation.
    """

    pair: np.ndarray  # (S,) index into the pairs
    sample: np.ndarray  # (S,) sample index
    entry: np.ndarray  # (S,) the shortest shadow of the caster that covers the sample, m (inf: none)
    height: np.ndarray  # (S,) the caster's least height, m
    height_max: np.ndarray  # (S,) the caster's greatest height, m
    unknown_top: np.ndarray  # (S,) bool the caster's top is not seen (height_max > height)


def _strip(pairs: _Pairs, azimuth: float) -> _Strip:
    """The pairs within the bounding strip of every shadow cast away from a sun at ``azimuth``."""
    return _strips(pairs, [azimuth])[0]


def _strips(pairs: _Pairs, azimuths: Sequence[float]) -> list[_Strip]:
    """:func:`_strip` of each azimuth: each strip's pairs found alone, the sweep entries of all
    of them in one batch (element by element, so each the same number)."""
    if not azimuths:
        return []
    bands, rates = [], []
    for azimuth in azimuths:
        away = -np.array([math.cos(azimuth), math.sin(azimuth)])
        margin = pairs.margin
        along = pairs.offset @ away
        across = pairs.offset @ np.array([-away[1], away[0]])
        band = np.flatnonzero((np.abs(across) <= margin) & (along >= -margin))
        bands.append(band)
        # each caster's (K, 2) @ (2,) once: the unit shadow direction along each half-plane's normal;
        # both gathered half-plane by half-plane, so sweep_entry reads contiguous columns
        rates.append((pairs.normals @ away).T[:, pairs.caster[band]])
    slack = np.concatenate([pairs.slack_by_plane[:, band] for band in bands], axis=1)
    entry = sweep_entry(slack.T, np.concatenate(rates, axis=1).T)
    entries = np.split(entry, np.cumsum([len(b) for b in bands])[:-1])
    out = []
    for band, entry in zip(bands, entries, strict=True):
        height, height_max = pairs.height[band], pairs.height_max[band]
        out.append(_Strip(band, pairs.sample[band], entry, height, height_max, height_max > height))
    return out


def _predicted_sets(
    strips: Sequence[_Strip], n_samples: int, elevations: Sequence[float], reach_max_m: float
) -> tuple[np.ndarray, np.ndarray]:
    """Samples in some caster's shadow for a sun at each strip's azimuth and each of some
    elevations, and those that may be.

    A caster whose top is not seen casts at least the shadow of its least height and at
    most that of its greatest: the ground between is unknown unless another caster's
    shadow surely covers it.

    Args:
        strips: the pairs of each azimuth (:func:`_strip`, the same for every elevation).
        n_samples: N, the number of ground samples.
        elevations: the sun's elevations, radians.
        reach_max_m: the longest shadow, metres.

    Returns:
        (A, E, N) bool surely shadowed samples per azimuth and elevation, and (A, E, N) bool
        samples that may or may not be.
    """
    owner = np.repeat(np.arange(len(strips)), [len(s.pair) for s in strips])
    joined = _Strip(
        *(np.concatenate([getattr(s, f.name) for s in strips]) for f in dataclasses.fields(_Strip))
    )
    sure = np.zeros((len(strips), len(elevations), n_samples), dtype=bool)
    rows, cols = np.nonzero(_covered(joined, elevations, reach_max_m, joined.height))
    sure[owner[cols], rows, joined.sample[cols]] = True
    unsure = np.zeros_like(sure)
    if np.any(joined.unknown_top):
        covered = _covered(joined, elevations, reach_max_m, joined.height_max)
        covered &= joined.unknown_top
        rows, cols = np.nonzero(covered)
        unsure[owner[cols], rows, joined.sample[cols]] = True
        unsure &= ~sure
    return sure, unsure


def _covered(
    strip: _Strip, elevations: Sequence[float], reach_max_m: float, height: np.ndarray
) -> np.ndarray:
    """(E, S) bool: the strip's pairs whose sample lies in the shadow of a caster of ``height``
    for each elevation (row): :func:`_strip_in_shadow`'s test, every elevation at once."""
    tangent = np.array([math.tan(e) for e in elevations])
    return strip.entry <= np.minimum(height / tangent[:, None], reach_max_m)


def _strip_in_shadow(
    strip: _Strip, elevations: Sequence[float], reach_max_m: float, height: np.ndarray, only: np.ndarray | None = None
) -> list[np.ndarray]:
    """Per elevation, (T,) int indices into the strip of the pairs whose sample lies in its caster's shadow.

    Args:
        strip: the pairs of one azimuth.
        elevations: the sun's elevations, radians.
        reach_max_m: the longest shadow, metres.
        height: (S,) float64 the casters' heights, metres.
        only: (S,) bool the pairs tested (default all).
    """
    out = []
    for elevation in elevations:
        covered = strip.entry <= np.minimum(height / math.tan(elevation), reach_max_m)
        if only is not None:
            covered &= only
        out.append(np.flatnonzero(covered))
    return out


def _overlap(
    pred: np.ndarray, observed: np.ndarray, weight: np.ndarray, unsure: np.ndarray | None = None
) -> float:
    """Weighted intersection over union of two (N,) bool sets, leaving out the (N,) bool ``unsure`` ones."""
    if unsure is not None:
        weight = np.where(unsure, 0.0, weight)
    union = float(weight[pred | observed].sum())
    return float(weight[pred & observed].sum()) / union if union > 0 else 0.0


def _overlaps(pred: np.ndarray, observed: np.ndarray, weight: np.ndarray, unsure: np.ndarray) -> list[float]:
    """:func:`_overlap` of each row of (E, N) bool ``pred`` and ``unsure`` with (N,) ``observed``:
    the element-wise steps for all rows at once, each row's sums as :func:`_overlap` adds them."""
    weights = np.where(unsure, 0.0, weight)
    union_sets = pred | observed
    inter_sets = pred & observed
    out = []
    for w, union_set, inter_set in zip(weights, union_sets, inter_sets):
        union = float(w[union_set].sum())
        out.append(float(w[inter_set].sum()) / union if union > 0 else 0.0)
    return out


def sample_weights(samples: _Samples) -> np.ndarray:
    """(N,) float64 weight of each sample: one over the sample count of the smallest ring holding it.

    Every caster's ring then weighs about the same in the fit, so a building's wide shadow
    (whose placement and height are the least sure) does not outvote the cars and people.
    """
    weight = np.zeros(len(samples.points_ground))
    for near in samples.neighbours:
        if len(near):
            weight[near] = np.maximum(weight[near], 1.0 / len(near))
    return weight


def fit_sun(
    casters: Sequence[ShadowCaster], samples: _Samples, params: LightParams
) -> tuple[float, float, float, np.ndarray, int]:
    """The azimuth and elevation whose predicted shadows overlap the observed ones best.

    A grid of ``coarse_step_deg`` over all azimuths and the elevation range, then a grid a
    third as fine around the best cell, then one of one degree. The ground that the shadow
    of a caster whose top is not seen may or may not reach (between the shadows of its
    least and its greatest height) counts neither way.

    The overlap returned is what the fit can be held to: its sure shadows against all the
    observed ones, the unknown ground counted as not predicted. Shadowed ground there is
    not explained by the fit (only a caster at least so tall would explain it, and its
    height there is not known) and lit ground there is not contradicted by it, so a sun
    that hides shadowed ground in the unknown band earns no trust for it.

    Returns:
        azimuth (rad), elevation (rad), the overlap of the sure shadows with the observed
        ones (weighted IoU), the (N,) bool sure predicted shadow and how many casters' sure
        shadows at the fit meet shadowed samples.
    """
    observed = samples.relative < 1.0 / params.sunny_min_contrast
    weight = sample_weights(samples)
    pairs = _pairs(casters, samples)
    n = len(samples.points_ground)
    lo, hi = params.elevation_range_deg

    strips: dict[float, _Strip] = {}
    scores: dict[tuple[float, float], float] = {}  # the refining grids meet cells already scored

    def clip(el: float) -> float:
        return float(min(max(float(el), lo), hi))  # np.clip's value for a finite scalar

    def score_all(azs: Sequence[float], els: Sequence[float]) -> None:
        """Score a sun at each of ``azs`` and each of ``els`` (clipped to the range) not scored yet,
        in one batch: the azimuths' strips together, then the sets of those with the same cells to score."""
        clipped = list(dict.fromkeys(map(clip, els)))
        groups: dict[tuple[float, ...], list[float]] = {}
        for az in map(float, azs):
            todo = tuple(e for e in clipped if (az, e) not in scores)
            if todo:
                groups.setdefault(todo, []).append(az)
        azimuths = (math.radians(az) for group in groups.values() for az in group)
        new = list(dict.fromkeys(a for a in azimuths if a not in strips))
        strips.update(zip(new, _strips(pairs, new), strict=True))
        for todo, group in groups.items():
            elevations = [math.radians(e) for e in todo]
            batch = [strips[math.radians(az)] for az in group]
            sure, unsure = _predicted_sets(batch, n, elevations, params.reach_max_m)
            for az, az_sure, az_unsure in zip(group, sure, unsure, strict=True):
                for e, overlap in zip(todo, _overlaps(az_sure, observed, weight, az_unsure), strict=True):
                    scores[(az, e)] = overlap

    def score(az: float, el: float) -> tuple[float, float, float]:
        el = clip(el)
        score_all([az], [el])
        return scores[(float(az), el)], az % 360.0, el

    step = params.coarse_step_deg
    coarse = np.arange(lo, hi + 1e-9, step)
    score_all(np.arange(0.0, 360.0, step), coarse)
    best = max(score(az, el) for az in np.arange(0.0, 360.0, step) for el in coarse)
    for fine in (step / 3.0, 1.0):
        _, az0, el0 = best
        offsets = np.arange(-3, 4) * fine
        score_all([az0 + da for da in offsets], [el0 + de for de in offsets])
        best = max([best] + [score(az0 + da, el0 + de) for da in offsets for de in offsets])
    _, az, el = best
    strip = _strip(pairs, math.radians(az))
    inside = np.zeros(len(pairs.sample), dtype=bool)
    inside[strip.pair[_strip_in_shadow(strip, [math.radians(el)], params.reach_max_m, strip.height)[0]]] = True
    pred = np.bincount(pairs.sample, weights=inside, minlength=n) > 0
    meeting = len(np.unique(pairs.caster[inside & observed[pairs.sample]]))
    return math.radians(az), math.radians(el), _overlap(pred, observed, weight), pred, meeting


def sky_colours(
    rgb: np.ndarray, sky_mask: np.ndarray, params: LightParams
) -> tuple[np.ndarray, np.ndarray]:
    """The sky's linear RGB at its top rows and at its bottom rows.

    Args:
        rgb: (H, W, 3) uint8 sRGB photo.
        sky_mask: (H, W) bool sky pixels (at least one).
        params: ``sky_top_fraction``.

    Returns:
        (3,) zenith and (3,) horizon linear RGB (medians).
    """
    per_row = np.count_nonzero(sky_mask, axis=1)
    total = int(per_row.sum())
    k = max(1, int(round(total * params.sky_top_fraction)))
    seen = np.cumsum(per_row)
    # the pixels in row order: the first k lie in the rows up to the one where k are seen,
    # the last k in the rows from the one after which total - k are seen
    first = int(np.searchsorted(seen, k))
    rows, cols = np.nonzero(sky_mask[: first + 1])
    top = rgb[rows[:k], cols[:k]]  # only the pixels measured
    last = int(np.searchsorted(seen, total - k, side="right"))
    end = int(np.searchsorted(seen, total)) + 1  # the rows below the sky's last hold none of it
    rows, cols = np.nonzero(sky_mask[last:end])
    bottom = rgb[rows[-k:] + last, cols[-k:]]
    return median_linear(top), median_linear(bottom)


def median_linear(pixels: np.ndarray) -> np.ndarray:
    """(3,) float64 the median linear RGB of 8-bit sRGB pixels, channel by channel (as ``np.median``).

    The decoding is monotonic, so the middle codes are found by counting the 256 codes
    of each channel and only they are decoded; an even count takes the mean of the two
    middle values, as ``np.median`` does.

    Args:
        pixels: (N, 3) uint8 sRGB, N >= 1.
    """
    table = uint8_to_linear(np.arange(256, dtype=np.uint8))
    n = len(pixels)
    out = np.empty(3)
    for c in range(3):
        seen = np.cumsum(np.bincount(pixels[:, c], minlength=256))
        upper = table[np.searchsorted(seen, n // 2, side="right")]  # the value at sorted position n // 2
        if n % 2:
            out[c] = upper
        else:
            lower = table[np.searchsorted(seen, n // 2 - 1, side="right")]
            out[c] = np.mean([lower, upper])
    return out


def sky_from_image(rgb: np.ndarray, horizon_v: float, blocked: np.ndarray) -> np.ndarray:
    """(H, W) bool: the bright, smooth part of the photo above the horizon (the sky, without labels).

    A pixel is sky when it lies above the horizon and outside every object, its luminance
    is at least the median of those pixels and its gradient at most theirs: the sky is the
    brightest and smoothest thing above a street.

    Args:
        rgb: (H, W, 3) uint8 sRGB photo.
        horizon_v: the horizon's row (may lie outside the image).
        blocked: (H, W) bool pixels of objects.
    """
    h, w = rgb.shape[:2]
    lum = luminance(rgb)
    above = np.zeros((h, w), dtype=bool)
    above[: int(np.clip(math.floor(horizon_v), 0, h))] = True
    above &= ~blocked
    if not np.any(above):
        return above
    gy, gx = np.gradient(lum)
    grad = np.hypot(gx, gy)
    return above & (lum >= np.median(lum[above])) & (grad <= np.median(grad[above]))


def estimate_light(
    rgb: np.ndarray,
    ground_ids: np.ndarray,
    sky_mask: np.ndarray,
    sky_source: str,
    casters: Sequence[ShadowCaster],
    ground_from_px: np.ndarray,
    default_azimuth: float,
    default_elevation: float,
    params: LightParams,
) -> LightEstimate:
    """The sun and sky of a photo (see the module docstring).

    Args:
        rgb: (H, W, 3) uint8 sRGB photo.
        ground_ids: (H, W) int surface id per pixel (road, sidewalk, terrain ... each its
            own id > 0), 0 where the ground is not seen.
        sky_mask: (H, W) bool sky pixels (may be empty).
        sky_source: how ``sky_mask`` was found: ``labels`` or ``image``.
        casters: the objects standing on the ground.
        ground_from_px: (3, 3) float64 homography from pixels to ground metres.
        default_azimuth: radians, the sun's azimuth when the photo shows none.
        default_elevation: radians, its elevation then.
        params: the light parameters.

    Returns:
        The estimate.
    """
    ground_ids = np.asarray(ground_ids)
    # the lit references on every k-th row and column (k = 1 up to reference_width_px wide)
    k = reference_stride(ground_ids.shape[1], params.reference_width_px)
    small_ids = inner_ground(ground_ids[::k, ::k], -(-params.edge_px // k))
    refs = lit_references(luminance(rgb[::k, ::k]), small_ids, params.lit_percentile)
    samples, used = _ring_samples(casters, rgb, ground_ids, refs, ground_from_px, params)
    if np.any(sky_mask):
        zenith, horizon = sky_colours(rgb, sky_mask, params)
        source = sky_source
    else:
        zenith = horizon = np.full(3, np.nan)
        source = "none"
    common = {"sky_zenith_linear": zenith, "sky_horizon_linear": horizon, "sky_source": source}
    if not used:
        return LightEstimate(
            "no_evidence", False, default_azimuth, default_elevation, math.nan, math.nan, math.nan, 0, 0, 0, **common
        )
    users = [casters[i] for i in used]
    dark = samples.relative < 1.0 / params.sunny_min_contrast
    weight = sample_weights(samples)
    share = float(weight[dark].sum() / weight.sum())
    contrast = float(1.0 / max(np.median(samples.relative[dark]), 1e-6)) if np.any(dark) else 1.0
    if share < params.min_shadow_share:
        return LightEstimate(
            "overcast", True, default_azimuth, default_elevation, contrast, share, math.nan, len(used), 0, 0, **common
        )
    az, el, score, pred, meeting = fit_sun(users, samples, params)
    n_shadow = int(np.count_nonzero(pred))
    if score < params.min_fit_iou or meeting < params.min_fit_casters:
        az, el, method = default_azimuth, default_elevation, "weak_fit"
    else:
        method = "cast_shadows"
    return LightEstimate(method, False, az, el, contrast, share, score, len(used), n_shadow, meeting, **common)

