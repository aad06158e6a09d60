"""Plane-to-plane homographies estimated by the normalised Direct Linear Transform.

This is step 2 of the paper ("perspective correction"): image pixels on the ground
map to ground metres through ``ground_from_px``. Hartley's normalisation (centroid
to the origin, mean distance sqrt(2)) conditions the linear system; the solution is
the right singular vector of the smallest singular value (||h|| = 1).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usdworld.errors import CalibrationError

#: Smallest ratio of the second to the first singular value of the centred points
#: below which a point set counts as collinear.
_COLLINEAR_RATIO = 1e-6


@dataclass(frozen=True)
class HomographyFit:
    """A homography and how well it fits its correspondences.

    Attributes:
        dst_from_src: (3, 3) float64 homography, scaled so that ||H||_F = 1 and H[2, 2] >= 0.
        src: (N, 2) float64 source points used.
        dst: (N, 2) float64 destination points used.
        rms_src: RMS error in source units of mapping ``dst`` back through the inverse.
        rms_dst: RMS transfer error in destination units.
    """

    dst_from_src: np.ndarray
    src: np.ndarray
    dst: np.ndarray
    rms_src: float
    rms_dst: float


def _normalisation(points: np.ndarray) -> np.ndarray:
    """(3, 3) similarity taking ``points`` to zero mean and mean distance sqrt(2)."""
    centroid = points.mean(axis=0)
    centred = points - centroid
    mean_dist = np.mean(np.linalg.norm(centred, axis=1))
    if not mean_dist > 0:
        raise CalibrationError("all correspondence points coincide; pick points spread over the ground")
    s = np.sqrt(2.0) / mean_dist
    return np.array([[s, 0.0, -s * centroid[0]], [0.0, s, -s * centroid[1]], [0.0, 0.0, 1.0]])


def _singular_values(matrix: np.ndarray, name: str) -> np.ndarray:
    """Singular values of ``matrix``; a CalibrationError when LAPACK does not converge."""
    try:
        return np.linalg.svd(matrix, compute_uv=False)
    except np.linalg.LinAlgError as exc:
        raise CalibrationError(
            f"the {name} points cannot be fitted ({exc}); check they are pixels and metres of sane size"
        ) from exc


def _check_points(name: str, points: np.ndarray) -> np.ndarray:
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 2:
        raise CalibrationError(f"{name} points must have shape (N, 2), got {points.shape}")
    if not np.all(np.isfinite(points)):
        raise CalibrationError(f"{name} points contain NaN or infinity")
    if len(points) < 4:
        raise CalibrationError(
            f"a homography needs at least 4 point pairs, got {len(points)}; add more ground points"
        )
    centred = points - points.mean(axis=0)
    sv = _singular_values(centred, name)
    if sv[0] == 0 or sv[1] / sv[0] < _COLLINEAR_RATIO:
        raise CalibrationError(
            f"the {name} points are collinear; pick ground points that are not all on one line"
        )
    return points


def apply_homography(dst_from_src: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Map points through a homography.

    Args:
        dst_from_src: (3, 3) float64 homography.
        points: (N, 2) float64 source points.

    Returns:
        (N, 2) float64 destination points; NaN where the point maps to infinity.
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    q = np.column_stack([p, np.ones(len(p))]) @ np.asarray(dst_from_src, dtype=np.float64).T
    with np.errstate(divide="ignore", invalid="ignore"):
        out = q[:, :2] / q[:, 2:3]
    out[~np.isfinite(out).all(axis=1)] = np.nan
    return out


def estimate_homography(src: np.ndarray, dst: np.ndarray) -> HomographyFit:
    """Estimate ``dst_from_src`` from >= 4 correspondences by normalised DLT.

    Args:
        src: (N, 2) float64 source points (e.g. pixels).
        dst: (N, 2) float64 destination points (e.g. ground metres), same order.

    Returns:
        The fit with its RMS transfer errors.

    Raises:
        CalibrationError: fewer than 4 pairs, mismatched counts, non-finite values,
            collinear point sets, or a degenerate (rank-deficient) system.

    Example:
        >>> H = np.array([[2.0, 0, 1], [0, 3, -1], [0, 0, 1]])
        >>> src = np.array([[0, 0], [1, 0], [0, 1], [1, 1], [2, 3]], float)
        >>> fit = estimate_homography(src, apply_homography(H, src))
        >>> bool(np.allclose(fit.dst_from_src / fit.dst_from_src[2, 2], H))
        True
    """
    src = _check_points("source", src)
    dst = _check_points("destination", dst)
    if len(src) != len(dst):
        raise CalibrationError(f"got {len(src)} source but {len(dst)} destination points; pair them up")
    T_src, T_dst = _normalisation(src), _normalisation(dst)
    s = apply_homography(T_src, src)
    d = apply_homography(T_dst, dst)
    n = len(s)
    A = np.zeros((2 * n, 9))
    A[0::2, 0:2] = s
    A[0::2, 2] = 1.0
    A[0::2, 6:8] = -d[:, 0:1] * s
    A[0::2, 8] = -d[:, 0]
    A[1::2, 3:5] = s
    A[1::2, 5] = 1.0
    A[1::2, 6:8] = -d[:, 1:2] * s
    A[1::2, 8] = -d[:, 1]
    try:
        # Economy SVD: (2N, 9) A needs only its 9 right singular vectors, not a (2N, 2N) U;
        # with 4 pairs (8 rows) the full V is needed for the null vector.
        _, sv, vt = np.linalg.svd(A, full_matrices=2 * n < 9)
    except np.linalg.LinAlgError as exc:
        raise CalibrationError(f"the homography fit did not converge ({exc}); spread the points out") from exc
    sv9 = np.concatenate([sv, np.zeros(9 - len(sv))])
    if sv9[-2] < 1e-10 * sv9[0]:
        raise CalibrationError("the correspondences do not determine a homography; spread the points out")
    H_norm = vt[-1].reshape(3, 3)
    H = np.linalg.inv(T_dst) @ H_norm @ T_src
    if abs(np.linalg.det(H)) < 1e-15 * np.linalg.norm(H) ** 3:
        raise CalibrationError("the estimated homography is singular; three or more points are collinear")
    H = H / np.linalg.norm(H)
    if H[2, 2] < 0:
        H = -H
    fwd = apply_homography(H, src)
    back = apply_homography(np.linalg.inv(H), dst)
    rms_dst = float(np.sqrt(np.mean(np.sum((fwd - dst) ** 2, axis=1))))
    rms_src = float(np.sqrt(np.mean(np.sum((back - src) ** 2, axis=1))))
    return HomographyFit(H, src.copy(), dst.copy(), rms_src, rms_dst)
