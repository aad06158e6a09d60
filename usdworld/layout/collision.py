"""Axis-aligned bounding-box collision resolution on the ground plane (step 3).

Objects are settled one at a time in a canonical order (most trusted first). Each is
moved by the smallest ground displacement that clears every object already settled,
searching the positions flush against their box edges. The result is deterministic,
does not depend on the input order, leaves no overlap beyond the tolerance, and is
idempotent: resolving an already resolved layout moves nothing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Boxes may overlap by at most this much (metres).
TOLERANCE_M = 0.01
#: Gap left between boxes that had to be separated (metres); below TOLERANCE_M.
_CLEARANCE_M = 0.005


@dataclass(frozen=True)
class CollisionResult:
    """Displacements that remove every footprint overlap.

    Attributes:
        displacement: (N, 2) float64 ground displacement of each box, metres.
        centers: (N, 2) float64 box centres after resolution.
    """

    displacement: np.ndarray
    centers: np.ndarray


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


def _clear(candidates: np.ndarray, half: np.ndarray, placed_c: np.ndarray, placed_h: np.ndarray) -> np.ndarray:
    """(K,) bool: candidate centres that overlap none of the placed boxes."""
    if len(placed_c) == 0:
        return np.ones(len(candidates), dtype=bool)
    gap = np.abs(candidates[:, None, :] - placed_c[None, :, :]) - (half[None, None, :] + placed_h[None, :, :])
    return ~np.any(np.all(gap < -TOLERANCE_M, axis=2), axis=1)


def _candidates(c0: np.ndarray, h: np.ndarray, pc: np.ndarray, ph: np.ndarray) -> np.ndarray:
    """(K, 2) candidate centres: the original coordinates or flush against placed box edges."""
    xs = np.concatenate([[c0[0]], pc[:, 0] - ph[:, 0] - h[0] - _CLEARANCE_M, pc[:, 0] + ph[:, 0] + h[0] + _CLEARANCE_M])
    ys = np.concatenate([[c0[1]], pc[:, 1] - ph[:, 1] - h[1] - _CLEARANCE_M, pc[:, 1] + ph[:, 1] + h[1] + _CLEARANCE_M])
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    return np.column_stack([X.ravel(), Y.ravel()])


def resolve_collisions(centers: np.ndarray, half: np.ndarray, priority: np.ndarray) -> CollisionResult:
    """Move boxes apart with minimal displacement.

    Args:
        centers: (N, 2) float64 box centres on the ground, metres.
        half: (N, 2) float64 half extents along x and y.
        priority: (N,) float64 sort key, smaller settles first (e.g. depth divided by
            confidence). Ties are broken by the box coordinates, never by input order.

    Returns:
        The displacements and the new centres.
    """
    centers = np.asarray(centers, dtype=np.float64).reshape(-1, 2)
    half = np.asarray(half, dtype=np.float64).reshape(-1, 2)
    priority = np.asarray(priority, dtype=np.float64).reshape(-1)
    order = np.lexsort((half[:, 1], half[:, 0], centers[:, 1], centers[:, 0], priority))
    out = centers.copy()
    placed: list[int] = []
    for i in order:
        c0, h = centers[i], half[i]
        pc, ph = out[placed], half[placed]
        if _clear(c0[None, :], h, pc, ph)[0]:
            placed.append(int(i))
            continue
        near = np.all(np.abs(pc - c0) < ph + h + 50.0, axis=1)
        best = _nearest_clear(c0, _candidates(c0, h, pc[near], ph[near]), h, pc, ph)
        if best is None:  # pushed out past the neighbourhood: consider every box's edges
            best = _nearest_clear(c0, _candidates(c0, h, pc, ph), h, pc, ph)
        out[i] = best
        placed.append(int(i))
    return CollisionResult(out - centers, out)


#: Candidates are checked in batches of this many, nearest first.
_BATCH = 64


def _nearest_clear(
    c0: np.ndarray, cand: np.ndarray, h: np.ndarray, pc: np.ndarray, ph: np.ndarray
) -> np.ndarray | None:
    """The candidate nearest ``c0`` (ties by x, then y) that overlaps no placed box, or None.

    Candidates are checked nearest first, a batch at a time, so that a free spot close
    by is found without checking the far ones.
    """
    order = np.lexsort((cand[:, 1], cand[:, 0], np.linalg.norm(cand - c0, axis=1)))
    for start in range(0, len(order), _BATCH):
        batch = cand[order[start : start + _BATCH]]
        ok = np.nonzero(_clear(batch, h, pc, ph))[0]
        if len(ok):
            return batch[ok[0]]
    return None
