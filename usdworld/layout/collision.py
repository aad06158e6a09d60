"""Axis-aligned bounding-box collision resolution on the ground plane (step 3).

Objects are settled one at a time in a canonical order (most trusted first). Each is
moved by the smallest ground displacement that clears every object already settled,
searching the positions flush against their box edges. The result is deterministic,
does not depend on the input order, leaves no overlap beyond the tolerance, and is
idempotent: resolving an already resolved layout moves nothing.

Dense scenes stay near-linear: the settled boxes sit in a uniform grid (:class:`_Grid`),
so a box is tested only against those in the cells it touches, and the candidate spots
are visited in rings of growing distance instead of being sorted all at once. Both only
skip work that cannot change the answer, so the result is the same, bit for bit, as
testing every pair and sorting every candidate (``tests/test_layout_collision.py`` keeps
that brute-force reference and compares the two).

The search is bounded. In a pile (many boxes on one spot) the candidates grow with the
boxes settled nearby and an exact search becomes cubic, so an object that would have to
move further than ``CollisionParams.max_displacement_m``, or whose search ring would
hold more than ``max_candidates`` spots, is not placed (``CollisionResult.placed``); the
caller drops it with a warning. No normal scene comes near either bound.

In a pile most boxes find no spot, and the exact rings would test every spot up to the
bound to say so. A coarse raster (:func:`usdworld.layout.occupancy.blocked_radius`) first
proves how far around the box every spot is blocked; the rings within that radius are
skipped, and a box whose whole search disk is blocked is refused at once. A proof only
skips spots that the exact test would reject, so the result stays the same bit for bit.

The photo bounds where a box may go (:class:`Admissible`, optional): an object is seen
along its pixels' rays, at a depth its cues allow. A box whose nearest free spot is nearer
the camera than its cues allow (where it would stand in front of what the photo shows),
or farther than a bound they give, takes the nearest free spot within its depths: the
grid's spots there, or a spot slid along its viewing ray (:func:`_along_ray`). When there is none, it is not placed
(``CollisionResult.contradicted``): boxes settle most trusted first, so it is the weaker
one of the pair, and pushing it elsewhere (in front of the camera, hiding what the photo
shows) would contradict its own pixels. Where the nearest free spot is allowed the result
is the unconstrained one, bit for bit.
"""

from __future__ import annotations

import bisect
import functools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from usdworld.layout.occupancy import blocked_radius
from usdworld.parameters.collision import CollisionParams

#: Boxes may overlap by at most this much (metres); the default of ``CollisionParams.tolerance_m``.
TOLERANCE_M = CollisionParams().tolerance_m

#: First ring radius of the candidate search, metres; the radius doubles until a spot is
#: free. Any positive value gives the same result; this one only sets how much is sorted.
_FIRST_RING_M = 1.0
#: Grid cells span this many times the median box half extent (a typical box touches <= 4 cells).
_CELL_PER_HALF = 2.0
#: A box touching more cells than this is kept in a list tested against every query.
_MAX_CELLS = 64
#: A query box spanning more cells than this returns every settled box instead.
_MAX_QUERY_CELLS = 4096

#: Coordinates beyond this magnitude (metres) are not indexed (tested against everything),
#: so float rounding (an ulp of 1e8 is 1.5e-8 m) stays far below the query padding.
_INDEX_LIMIT_M = 1e8
#: Query boxes are padded by this much (metres) so that rounding never hides a pair.
_PAD_M = 1e-6


@dataclass(frozen=True)
class CollisionResult:
    """Displacements that remove every footprint overlap.

    Attributes:
        displacement: (N, 2) float64 ground displacement of each box, metres.
        centers: (N, 2) float64 box centres after resolution.
        placed: (N,) bool, False for a box not placed: it would have had to move further
            than ``max_displacement_m`` or search a ring of over ``max_candidates`` spots (its displacement
            is zero and its centre the input one; no other box was settled against it).
        pair_checks: how many (candidate spot, settled box) overlap tests were made; a
            measure of the work, near-linear in N for a dense scene.
    """

    displacement: np.ndarray
    centers: np.ndarray
    placed: np.ndarray
    pair_checks: int = 0
    contradicted: np.ndarray | None = None


@dataclass(frozen=True)
class Admissible:
    """How near and how far the photo allows each box's centre: an object is seen along its
    pixels' rays, so it may not come nearer the camera than its depth cues allow (there it
    would stand in front of what the photo shows), nor farther than a bound they give.

    Attributes:
        eye: (2,) float64 the camera centre on the ground (the rays' origin).
        depth_axis: (2,) float64: a ground point's optical depth is
            ``depth_axis @ p + depth_offset`` (metres; affine on the ground plane).
        depth_offset: metres.
        depth: (N, 2) float64 nearest and farthest centre depth allowed, metres.
    """

    eye: np.ndarray
    depth_axis: np.ndarray
    depth_offset: float
    depth: np.ndarray

    def allows(self, i: int, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """(NX, NY) bool: which spots (xs[a], ys[b]) box ``i`` may take.

        Args:
            i: the box.
            xs, ys: (NX,) and (NY,) float64 candidate coordinates.
        """
        depth = self.depth_axis[0] * xs[:, None] + self.depth_axis[1] * ys[None, :] + self.depth_offset
        dlo, dhi = self.depth[i]
        return (depth >= dlo) & (depth <= dhi)


def footprint_half_extents(size_lw: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """Half extents along world x and y of rotated rectangular footprints.

    Args:
        size_lw: (N, 2) float64 length (object forward) and width, metres.
        yaw: (N,) float64 rotation about Z, radians.

    Returns:
        (N, 2) float64 half extents of the axis-aligned boxes.
    """
    size_lw = np.asarray(size_lw, dtype=np.float64).reshape(-1, 2)
    c, s = np.abs(np.cos(yaw)), np.abs(np.sin(yaw))
    hx = 0.5 * (size_lw[:, 0] * c + size_lw[:, 1] * s)
    hy = 0.5 * (size_lw[:, 0] * s + size_lw[:, 1] * c)
    return np.column_stack([hx, hy])


def overlaps(centers: np.ndarray, half: np.ndarray, tol: float = TOLERANCE_M) -> list[tuple[int, int]]:
    """Pairs (i < j) of boxes that overlap by more than ``tol`` on both axes.

    Args:
        centers: (N, 2) float64 box centres.
        half: (N, 2) float64 half extents.
        tol: allowed overlap, metres.
    """
    centers = np.asarray(centers, dtype=np.float64).reshape(-1, 2)
    half = np.asarray(half, dtype=np.float64).reshape(-1, 2)
    gap = np.abs(centers[:, None, :] - centers[None, :, :]) - (half[:, None, :] + half[None, :, :])
    hit = np.all(gap < -tol, axis=2)
    i, j = np.nonzero(np.triu(hit, k=1))
    return list(zip(i.tolist(), j.tolist()))


class _Grid:
    """Uniform grid over the settled boxes' AABBs: which boxes may touch a query box.

    A query returns a superset of the boxes whose AABB intersects the (padded) query box;
    the exact overlap test is then made on those alone.
    """

    def __init__(self, cell_m: float) -> None:
        self.cell = cell_m
        self.cells: dict[tuple[int, int], list[int]] = {}
        self.wide: list[int] = []  # boxes not indexed: tested against every query
        self.placed: list[int] = []

    def _cells(
        self, x0: float, y0: float, x1: float, y1: float, limit: int = _MAX_CELLS
    ) -> tuple[range, range] | None:
        """Cell ranges covering [x0, x1] x [y0, y1], or None when not indexable (more than ``limit`` cells)."""
        if not all(math.isfinite(v) and abs(v) <= _INDEX_LIMIT_M for v in (x0, y0, x1, y1)):
            return None
        ix = range(math.floor(x0 / self.cell), math.floor(x1 / self.cell) + 1)
        iy = range(math.floor(y0 / self.cell), math.floor(y1 / self.cell) + 1)
        return (ix, iy) if len(ix) * len(iy) <= limit else None

    def insert(self, k: int, center: np.ndarray, half: np.ndarray) -> None:
        """Add box ``k`` (centre and half extents, (2,) float64 each)."""
        self.placed.append(k)
        span = self._cells(center[0] - half[0], center[1] - half[1], center[0] + half[0], center[1] + half[1])
        if span is None:
            self.wide.append(k)
            return
        for ix in span[0]:
            for iy in span[1]:
                self.cells.setdefault((ix, iy), []).append(k)

    def query(self, x0: float, y0: float, x1: float, y1: float) -> list[int]:
        """Settled boxes that may intersect [x0, x1] x [y0, y1] (repeats possible)."""
        span = self._cells(x0 - _PAD_M, y0 - _PAD_M, x1 + _PAD_M, y1 + _PAD_M, _MAX_QUERY_CELLS)
        if span is None:
            return list(self.placed)
        found = list(self.wide)
        for ix in span[0]:
            for iy in span[1]:
                found.extend(self.cells.get((ix, iy), ()))
        return found


class _Settled:
    """The boxes settled so far, indexed, with the overlap test against them."""

    def __init__(self, out: np.ndarray, half: np.ndarray, tol: float) -> None:
        med = float(np.median(np.max(half, axis=1))) if len(half) else 0.0
        self.grid = _Grid(max(_CELL_PER_HALF * med, 0.1) if math.isfinite(med) else 1.0)
        self.out, self.half, self.tol = out, half, tol
        self.rank = np.full(len(out), -1, dtype=np.int64)
        self.checks = 0

    def add(self, i: int) -> None:
        self.rank[i] = len(self.grid.placed)
        self.grid.insert(i, self.out[i], self.half[i])

    def around(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """(M,) int64 settled boxes, ascending, that may touch the box from ``lo`` to ``hi``
        ((2,) float64 each). A query over more grid cells than there are settled boxes
        tests every box at once instead (the same boxes, and maybe more that are far off)."""
        span = self.grid._cells(lo[0] - _PAD_M, lo[1] - _PAD_M, hi[0] + _PAD_M, hi[1] + _PAD_M, _MAX_QUERY_CELLS)
        if span is not None and len(span[0]) * len(span[1]) <= len(self.grid.placed):
            return np.array(sorted(set(self.grid.query(lo[0], lo[1], hi[0], hi[1]))), dtype=np.int64)
        ids = np.array(self.grid.placed, dtype=np.int64)
        c, hh = self.out[ids], self.half[ids]
        apart = np.any((c - hh > hi + _PAD_M) | (c + hh < lo - _PAD_M), axis=1)  # NaN is never apart
        return np.sort(ids[~apart])

    def clear(self, cand: np.ndarray, h: np.ndarray, ids: np.ndarray) -> np.ndarray:
        """(K,) bool: candidate centres ((K, 2) float64, half extents ``h``) that overlap none of
        the settled boxes ``ids`` ((M,) int64, at least those that may touch a candidate)."""
        self.checks += len(cand) * len(ids)
        if len(ids) == 0:
            return np.ones(len(cand), dtype=bool)
        gap = np.abs(cand[:, None, :] - self.out[ids][None, :, :]) - (h[None, None, :] + self.half[ids][None, :, :])
        return ~np.any(np.all(gap < -self.tol, axis=2), axis=1)

    def near(self, c0: np.ndarray, h: np.ndarray, reach: float) -> np.ndarray:
        """Settled boxes, in settling order, with ``|c - c0| < half + h + reach`` on both axes."""
        ids = self.around(c0 - h - reach, c0 + h + reach)
        ids = ids[np.argsort(self.rank[ids])]
        keep = np.all(np.abs(self.out[ids] - c0) < self.half[ids] + h + reach, axis=1)
        return ids[keep]


def resolve_collisions(
    centers: np.ndarray,
    half: np.ndarray,
    priority: np.ndarray,
    params: CollisionParams = CollisionParams(),
    admissible: Admissible | None = None,
) -> CollisionResult:
    """Move boxes apart with minimal displacement.

    Args:
        centers: (N, 2) float64 box centres on the ground, metres.
        half: (N, 2) float64 half extents along x and y.
        priority: (N,) float64 sort key, smaller settles first (e.g. depth divided by
            confidence). Ties are broken by the box coordinates, never by input order.
        params: tolerance, clearance, search neighbourhood and the search's bounds
            (``max_displacement_m``, ``max_candidates``).
        admissible: where the photo allows each box (None: anywhere). A box whose nearest
            free spot is outside it takes the nearest free spot inside, or is not placed.

    Returns:
        The displacements, the new centres and which boxes were placed; ``contradicted``
        (with ``admissible``) marks the boxes not placed although a free spot existed
        outside what the photo allows.
    """
    centers = np.asarray(centers, dtype=np.float64).reshape(-1, 2)
    half = np.asarray(half, dtype=np.float64).reshape(-1, 2)
    priority = np.asarray(priority, dtype=np.float64).reshape(-1)
    order = np.lexsort((half[:, 1], half[:, 0], centers[:, 1], centers[:, 0], priority))
    out = centers.copy()
    placed = np.ones(len(centers), dtype=bool)
    contradicted = np.zeros(len(centers), dtype=bool)
    settled = _Settled(out, half, params.tolerance_m)
    for i in order:
        c0, h = centers[i], half[i]
        if settled.clear(c0[None, :], h, settled.around(c0 - h, c0 + h))[0]:
            settled.add(int(i))
            continue
        search = _Search(params.clearance_m, params.max_displacement_m, params.max_candidates)
        best = _free_spot(c0, h, settled, search, params, None)
        if best is not None and admissible is not None:
            if not admissible.allows(int(i), best[:1], best[1:])[0, 0]:
                allow = functools.partial(admissible.allows, int(i))
                inside = _free_spot(c0, h, settled, search, params, allow)
                along = _along_ray(c0, h, settled, search, admissible, int(i))
                if inside is None or (along is not None and _nearer(along, inside, c0)):
                    inside = along
                contradicted[i] = inside is None
                best = inside
        if best is None:  # no free spot within the bounds (a pile), or none the photo allows: not placed
            placed[i] = False
            continue
        out[i] = best
        settled.add(int(i))
    return CollisionResult(out - centers, out, placed, settled.checks, contradicted)


def _free_spot(
    c0: np.ndarray,
    h: np.ndarray,
    settled: _Settled,
    search: _Search,
    params: CollisionParams,
    allow: Callable[[np.ndarray, np.ndarray], np.ndarray] | None,
) -> np.ndarray | None:
    """The nearest free spot (:func:`_nearest_clear`) against the settled boxes in the
    neighbourhood, then against every settled box; (2,) float64 or None."""
    near = settled.near(c0, h, params.neighbourhood_m)
    best = _nearest_clear(c0, h, settled.out[near], settled.half[near], settled, search, allow)
    if best is None and params.max_displacement_m > params.neighbourhood_m:
        # pushed out past the neighbourhood: consider every box's edges
        every = np.array(settled.grid.placed, dtype=np.int64)
        best = _nearest_clear(c0, h, settled.out[every], settled.half[every], settled, search, allow)
    return best


def _nearer(a: np.ndarray, b: np.ndarray, c0: np.ndarray) -> bool:
    """True when spot ``a`` is nearer ``c0`` than ``b`` (ties by x, then y); (2,) float64 each."""
    da, db = float(np.linalg.norm(a - c0)), float(np.linalg.norm(b - c0))
    return (da, a[0], a[1]) < (db, b[0], b[1])


def _along_ray(
    c0: np.ndarray, h: np.ndarray, settled: _Settled, search: _Search, admissible: Admissible, i: int
) -> np.ndarray | None:
    """The free spot nearest ``c0`` on the camera's ray through it, within box ``i``'s
    allowed depths and ``search.max_m``; (2,) float64 or None.

    Along the ray ``c0 + t r`` each settled box blocks an open interval of ``t`` (where the
    two boxes, grown by the clearance, overlap on both axes); the free ``t`` nearest 0 is 0
    or an end of one of them. The ends are tested with :meth:`_Settled.clear`.

    Args:
        c0: (2,) float64 the box's drafted centre.
        h: (2,) float64 its half extents.
        settled: the boxes settled so far.
        search: clearance and the search's radius.
        admissible: the allowed region (its ``depth`` bounds ``t``).
        i: the box.
    """
    ray = c0 - admissible.eye
    length = float(np.linalg.norm(ray))
    if not length > 0:
        return None
    r = ray / length
    slope = float(admissible.depth_axis @ r)  # depth gained per metre along the ray
    if not slope > 0:
        return None
    d0 = float(admissible.depth_axis @ c0 + admissible.depth_offset)
    dlo, dhi = admissible.depth[i]
    t_lo = max((dlo - d0) / slope, -search.max_m, -length)
    t_hi = min((dhi - d0) / slope, search.max_m)
    if not t_lo <= t_hi:
        return None
    a, b = c0 + t_lo * r, c0 + t_hi * r
    pad = h + search.clearance
    ids = settled.around(np.minimum(a, b) - pad, np.maximum(a, b) + pad)
    if len(ids) == 0:
        return None
    reach = h + settled.half[ids] + search.clearance  # (M, 2)
    offset = settled.out[ids] - c0  # (M, 2)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        e0, e1 = (offset - reach) / r, (offset + reach) / r
    enter = np.where(r == 0.0, np.where(np.abs(offset) < reach, -np.inf, np.inf), np.minimum(e0, e1))
    leave = np.where(r == 0.0, np.where(np.abs(offset) < reach, np.inf, -np.inf), np.maximum(e0, e1))
    lo, hi = enter.max(axis=1), leave.min(axis=1)
    crossed = lo < hi
    ts = np.concatenate([[0.0], lo[crossed], hi[crossed]])
    ts = ts[np.isfinite(ts) & (ts >= t_lo) & (ts <= t_hi)]
    if len(ts) == 0:
        return None
    ts = ts[np.lexsort((ts, np.abs(ts)))]
    spots = c0[None, :] + ts[:, None] * r[None, :]
    free = settled.clear(spots, h, ids)
    if not free.any():
        return None
    return spots[int(np.argmax(free))]


@dataclass
class _Search:
    """The bounds of one object's search for a free spot.

    Attributes:
        clearance: gap left to the boxes moved against, metres.
        max_m: candidates further than this from the original centre are not considered, metres.
        most: the most candidate spots one ring may hold.
    """

    clearance: float
    max_m: float
    most: int


def _nearest_clear(
    c0: np.ndarray,
    h: np.ndarray,
    pc: np.ndarray,
    ph: np.ndarray,
    settled: _Settled,
    search: _Search,
    allow: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
) -> np.ndarray | None:
    """The candidate nearest ``c0`` (ties by x, then y) that overlaps no settled box, or None.

    The candidates are the grid of the original coordinates and the positions flush
    against the edges of the boxes ``pc``/``ph`` ((M, 2) float64 each), within
    ``search.max_m`` of ``c0``. They are visited in rings: every candidate within a radius
    (a square of xs by ys), then the next ring, twice as wide. In a ring, the overlap test
    factorises by axis (a spot overlaps a box when its x and its y both do, each tested
    with the same float operations as :meth:`_Settled.clear`), so the blocked spots are
    one boolean matrix product; the free new spot first in the order (distance, x, y)
    (the distance computed as ``np.linalg.norm`` does) is the one sorting all candidates
    at once would give. None also when a ring's square holds more than ``search.most`` spots.
    Rings within the radius that :func:`~usdworld.layout.occupancy.blocked_radius` proves
    blocked by the boxes ``pc`` are not tested (a proof from some of the settled boxes
    holds for all of them). With ``allow`` (spots ``(xs, ys)`` -> (NX, NY) bool), only the
    spots it allows count as free.
    """
    clearance, max_m = search.clearance, search.max_m
    xs = np.concatenate([[c0[0]], pc[:, 0] - ph[:, 0] - h[0] - clearance, pc[:, 0] + ph[:, 0] + h[0] + clearance])
    ys = np.concatenate([[c0[1]], pc[:, 1] - ph[:, 1] - h[1] - clearance, pc[:, 1] + ph[:, 1] + h[1] + clearance])
    kx, ky = np.nonzero(np.abs(xs - c0[0]) <= max_m)[0], np.nonzero(np.abs(ys - c0[1]) <= max_m)[0]
    xs, ix = _distinct(xs[kx])
    ys, iy = _distinct(ys[ky])
    ix, iy = kx[ix], ky[iy]  # positions in the full candidate lists: the same tie-breaks
    dx, dy = xs - c0[0], ys - c0[1]
    dx2, dy2 = dx * dx, dy * dy
    rx, ry = np.sqrt(dx2), np.sqrt(dy2)  # a candidate's distance is at least each of these
    examined = _examined_radius(rx, ry, max_m, search.most)
    if examined is None:
        return None
    settled.checks += len(pc)
    blocked = blocked_radius(c0, h, examined, pc, ph, settled.tol)  # every spot this near is blocked
    if blocked >= examined:
        return None  # every spot the rings would examine is blocked: the same None, found cheaply
    done, reach = -np.inf, min(_FIRST_RING_M, max_m)
    while True:
        last = not reach < max_m or (bool(np.all(rx <= reach)) and bool(np.all(ry <= reach)))
        r = max_m if last else reach
        if not r <= blocked:  # else every spot within r is blocked (and the ring is under the cap)
            sx, sy = np.nonzero(rx <= r)[0], np.nonzero(ry <= r)[0]
            if len(sx) * len(sy) > search.most:  # a pile: too many spots to consider
                return None
            dist = np.sqrt(dx2[sx][:, None] + dy2[sy][None, :])
            new = (dist <= r) & ~(dist <= done)
            if new.any():
                lo = np.array([xs[sx].min(), ys[sy].min()])
                hi = np.array([xs[sx].max(), ys[sy].max()])
                ids = settled.around(lo - h, hi + h)
                settled.checks += (len(sx) + len(sy)) * len(ids)
                if len(ids):
                    ox, oy = settled.out[ids, 0], settled.out[ids, 1]
                    hx, hy = settled.half[ids, 0], settled.half[ids, 1]
                    new &= ~_blocked(xs[sx], ys[sy], ox, oy, h[0] + hx, h[1] + hy, settled.tol)
                if allow is not None:
                    new &= allow(xs[sx], ys[sy])
                a, b = np.nonzero(new)
                if len(a):
                    k = np.lexsort((iy[sy][b], ix[sx][a], ys[sy][b], xs[sx][a], dist[a, b]))[0]
                    return np.array([xs[sx][a[k]], ys[sy][b[k]]])
        if last:
            return None
        done, reach = reach, min(reach * 2.0, max_m)


def _examined_radius(rx: np.ndarray, ry: np.ndarray, max_m: float, most: int) -> float | None:
    """How far from the original centre the rings of :func:`_nearest_clear` test spots.

    The rings' sizes depend on the candidates alone, so this follows them without any
    overlap test: the search examines every spot within the returned radius before it
    returns None, either past ``max_m`` or at the first ring over ``most`` spots.

    Args:
        rx, ry: (NX,) and (NY,) float64 distances of the candidate coordinates along each axis.
        max_m: the search's radius, metres.
        most: the most spots one ring may hold.

    Returns:
        The radius, metres, or None when the first ring is already over ``most`` spots.
    """
    # Sorted Python floats: bisect_right counts what np.searchsorted(side="right") counts
    # (the distances are finite: the candidates are within max_m).
    rx, ry = sorted(rx.tolist()), sorted(ry.tolist())
    top = max(rx[-1] if len(rx) else -np.inf, ry[-1] if len(ry) else -np.inf)  # none within a bound < 0
    done, reach = None, min(_FIRST_RING_M, max_m)
    while True:
        last = not reach < max_m or bool(top <= reach)
        r = max_m if last else reach
        if bisect.bisect_right(rx, r) * bisect.bisect_right(ry, r) > most:
            return done
        if last:
            return r
        done, reach = reach, min(reach * 2.0, max_m)


def _blocked(
    xv: np.ndarray, yv: np.ndarray, ox: np.ndarray, oy: np.ndarray, wx: np.ndarray, wy: np.ndarray, tol: float
) -> np.ndarray:
    """(NX, NY) bool: which spots (xv[a], yv[b]) overlap one of M boxes.

    A spot overlaps box m when ``|x - ox[m]| - wx[m] < -tol`` and likewise in y (the
    float operations of :meth:`_Settled.clear`, so the answer is the same bit for bit).
    Each test is monotone in ``|x - ox[m]|``, which rounding keeps unimodal in x, so the
    coordinates that pass form an interval in sorted order: each box adds one to a
    rectangle of a difference array, summed in O(NX NY + (NX + NY) M).

    Args:
        xv, yv: (NX,) and (NY,) float64 candidate coordinates.
        ox, oy: (M,) float64 box centres.
        wx, wy: (M,) float64 summed half extents (the spot's plus the box's).
        tol: allowed overlap, metres.
    """
    px, py = np.argsort(xv, kind="stable"), np.argsort(yv, kind="stable")
    in_x = np.abs(xv[px][:, None] - ox[None, :]) - wx[None, :] < -tol
    in_y = np.abs(yv[py][:, None] - oy[None, :]) - wy[None, :] < -tol
    hit = np.nonzero(in_x.any(axis=0) & in_y.any(axis=0))[0]
    nx, ny = len(xv), len(yv)
    if len(hit) == 0:
        return np.zeros((nx, ny), dtype=bool)
    in_x, in_y = in_x[:, hit], in_y[:, hit]
    x0, x1 = np.argmax(in_x, axis=0), nx - np.argmax(in_x[::-1], axis=0)
    y0, y1 = np.argmax(in_y, axis=0), ny - np.argmax(in_y[::-1], axis=0)
    diff = np.zeros((nx + 1, ny + 1), dtype=np.int32)
    np.add.at(diff, (x0, y0), 1)
    np.add.at(diff, (x0, y1), -1)
    np.add.at(diff, (x1, y0), -1)
    np.add.at(diff, (x1, y1), 1)
    inside = np.cumsum(np.cumsum(diff, axis=0), axis=1)[:nx, :ny] > 0
    out = np.empty((nx, ny), dtype=bool)
    out[np.ix_(px, py)] = inside
    return out


def _distinct(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Values that differ in their bits, each with the index of its first occurrence.

    Args:
        values: (K,) float64.

    Returns:
        (M,) float64 values and (M,) int64 indices into ``values``. Equal bits give equal
        results everywhere, so one copy suffices; 0.0 and -0.0 stay apart, and the first
        index breaks their tie as the position in the full candidate list would.
    """
    values = np.ascontiguousarray(values, dtype=np.float64)
    _, first = np.unique(values.view(np.int64), return_index=True)
    return values[first], first
