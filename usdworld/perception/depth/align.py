"""Metric alignment of a depth prediction to the ground plane seen by the camera.

A monocular network does not know metres. On road and sidewalk pixels the camera
gives the true depth ``g`` (the ground plane, :func:`ground_plane_depth`), so the
unknown scale (and shift) of the prediction ``v`` can be fitted there:

==================  ===================  ================  ============================
prediction kind     model                space             relative residual
==================  ===================  ================  ============================
metric, relative    ``g = s v``          ``depth``         ``s v / g - 1``
affine_invariant    ``g = s v + t``      ``depth``         ``(s v + t) / g - 1``
disparity           ``1/g = s v + t``    ``inverse_depth`` ``(s v + t) g - 1``
==================  ===================  ================  ============================

Residuals are relative (a fraction of the depth) in both spaces, so near and far
ground pixels count alike and one threshold serves all kinds; both are linear in
``(s, t)``. The estimator is RANSAC on minimal samples (1 pixel for scale, 2 for scale
and shift; ranked by the truncated squared residual, MSAC) followed by iteratively reweighted least squares with Tukey's biweight
(scale from the median absolute residual). Random choices come from the ``rng`` argument (default: seed 0), so the fit
is deterministic.

Failure is an exception, never a silent fallback: without a camera, with too few
ground pixels, or with a fit that explains too few of them,
:func:`align_to_ground` raises :class:`~usdworld.errors.CalibrationError`. The caller
catches it and records that depth stays relative (and how it was scaled instead).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Literal

import numpy as np

from usdworld.errors import CalibrationError, InputError
from usdworld.geometry.camera import PinholeCamera
from usdworld.io.types import DepthMap
from usdworld.parameters.perception import DEFAULT_PERCEPTION, PerceptionParams
from usdworld.perception.depth.base import DepthPrediction
from usdworld.perception.depth.ground import ground_plane_depth

log = logging.getLogger(__name__)

AlignmentSpace = Literal["depth", "inverse_depth"]

@dataclass(frozen=True)
class AlignmentFit:
    """Result of fitting a prediction to the ground.

    Attributes:
        scale: s (> 0), in the model of ``space``.
        shift: t (0 when only a scale was fitted); metres in ``depth`` space,
            1/metres in ``inverse_depth`` space.
        inlier_ratio: fraction of the used ground pixels whose relative residual is
            below the threshold.
        residual_m: median absolute depth error on the inliers, metres.
        n_pixels: ground pixels used (after subsampling).
        space: ``depth`` (``g = s v + t``) or ``inverse_depth`` (``1/g = s v + t``).
    """

    scale: float
    shift: float
    inlier_ratio: float
    residual_m: float
    n_pixels: int
    space: AlignmentSpace

    def __post_init__(self) -> None:
        if not (np.isfinite(self.scale) and self.scale > 0):
            raise CalibrationError(f"depth alignment: scale must be > 0, got {self.scale}")
        if self.space not in ("depth", "inverse_depth"):
            raise CalibrationError(f"depth alignment: unknown space {self.space!r}")

    def apply(self, values: np.ndarray) -> np.ndarray:
        """Metric depth from prediction values.

        Args:
            values: (...) prediction values.

        Returns:
            (...) float64 depth in metres (may be <= 0 or inf where the model breaks down).
        """
        v = np.asarray(values, dtype=np.float64)
        if self.space == "depth":
            return self.scale * v + self.shift
        with np.errstate(divide="ignore"):
            return 1.0 / (self.scale * v + self.shift)


def _space_and_shift(prediction: DepthPrediction) -> tuple[AlignmentSpace, bool]:
    if prediction.kind == "disparity":
        return "inverse_depth", True
    return "depth", prediction.kind == "affine_invariant"


def _design(values: np.ndarray, ground_m: np.ndarray, space: AlignmentSpace, with_shift: bool) -> np.ndarray:
    """(N, 1 or 2) rows ``A`` such that the relative residual is ``A @ p - 1``."""
    c = 1.0 / ground_m if space == "depth" else ground_m
    cols = [values * c, c] if with_shift else [values * c]
    return np.column_stack(cols)


def _ransac(
    A: np.ndarray, threshold: float, iterations: int, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Best parameters on minimal samples (least truncated squared residual) and their inlier mask."""
    n, k = A.shape
    first = rng.integers(n, size=iterations)
    if k == 1:
        idx = first[:, None]
    else:  # a second, distinct pixel
        idx = np.column_stack([first, (first + 1 + rng.integers(n - 1, size=iterations)) % n])  # (I, 2)
    sub = A[idx]  # (I, k, k)
    if k == 1:
        with np.errstate(divide="ignore"):
            params = 1.0 / sub[:, 0, :]  # (I, 1)
        ok = np.isfinite(params[:, 0])
    else:
        det = np.linalg.det(sub)
        ok = np.abs(det) > 1e-12 * np.max(np.abs(sub), axis=(1, 2)) ** 2
        params = np.zeros((iterations, k))
        params[ok] = np.linalg.solve(sub[ok], np.ones((int(ok.sum()), k, 1)))[..., 0]
    ok &= params[:, 0] > 0
    if not ok.any():
        raise CalibrationError(
            "depth alignment: every RANSAC sample was degenerate (prediction constant on the ground?)"
        )
    params = params[ok]
    # MSAC: the truncated squared residual, not the inlier count, ranks the samples. A
    # count ties the exact model with one at the band's edge that also takes in some
    # outliers, and the IRLS below then follows those outliers away from the inliers.
    cost = np.minimum((A @ params.T - 1.0) ** 2, threshold**2).sum(axis=0)  # (I,)
    best = params[int(np.argmin(cost))]
    return best, np.abs(A @ best - 1.0) < threshold


def _irls(
    A: np.ndarray, p: np.ndarray, threshold: float, iterations: int = 20
) -> tuple[np.ndarray, np.ndarray]:
    """Tukey-biweight IRLS from the RANSAC estimate; returns parameters and threshold inliers.

    The residual scale is re-estimated each round as 1.4826 x the median absolute
    residual of the current inliers, the biweight cut-off is 4.685 scales (95 %
    efficiency under Gaussian noise) and never more than ``threshold``. The
    redescending weights give zero weight to outliers that RANSAC's threshold let in,
    so noise-free inliers are fitted exactly.
    """
    k = A.shape[1]
    for _ in range(iterations):
        r = A @ p - 1.0
        near = np.abs(r) < threshold
        if near.sum() < k:
            break
        sigma = max(1.4826 * float(np.median(np.abs(r[near]))), 1e-9)
        u = r / min(4.685 * sigma, threshold)
        w = np.where(np.abs(u) < 1.0, (1.0 - u**2) ** 2, 0.0)
        if np.count_nonzero(w) < k:
            break
        sw = np.sqrt(w)
        p_new, *_ = np.linalg.lstsq(A * sw[:, None], sw, rcond=None)
        if not p_new[0] > 0:
            break
        converged = np.allclose(p_new, p, rtol=1e-12, atol=1e-15)
        p = p_new
        if converged:
            break
    return p, np.abs(A @ p - 1.0) < threshold


def align_to_ground(
    prediction: DepthPrediction,
    ground_mask: np.ndarray,
    camera: PinholeCamera | None,
    rng: np.random.Generator | None = None,
    *,
    threshold: float = 0.1,
    iterations: int = 200,
    max_samples: int = 20000,
    params: PerceptionParams = DEFAULT_PERCEPTION,
) -> tuple[AlignmentFit, DepthMap]:
    """Fit a prediction's scale (and shift) to the ground plane and return metric depth.

    Args:
        prediction: any kind (``metric`` ones are rescaled, e.g. a model trained on
            another camera).
        ground_mask: (H, W) bool, road/sidewalk pixels.
        camera: the photo's camera; None raises (depth stays relative).
        rng: random generator for RANSAC and subsampling; default
            ``np.random.default_rng(0)``.
        threshold: inlier threshold on the relative residual (0.1 = 10 % of the depth).
        iterations: RANSAC samples.
        max_samples: ground pixels used at most (a random subset beyond that).
        params: the alignment's limits (``align_max_ground_depth_m``, ``align_max_depth_m``,
            ``align_min_ground_pixels``, ``align_min_inlier_ratio``).

    Returns:
        fit: the fitted model and its quality.
        depth_map: (H, W) metric depth, ``source = "<name>:ground-aligned"``; pixels where
            the model gives a non-positive, non-finite or too far (``align_max_depth_m``)
            depth are invalid.

    Raises:
        CalibrationError: no camera, too few usable ground pixels, a degenerate
            prediction, or too few inliers.
        InputError: mask or camera size differs from the prediction's.

    Example:
        >>> fit, depth_map = align_to_ground(pred, labels_are_road, camera)  # doctest: +SKIP
        >>> fit.scale, fit.inlier_ratio  # doctest: +SKIP
        (12.3, 0.94)
    """
    where = f"depth alignment of {prediction.name}"
    if camera is None:
        raise CalibrationError(f"{where}: no camera, so depth stays {prediction.kind.replace('_', '-')}")
    mask = np.asarray(ground_mask, dtype=bool)
    if mask.shape != prediction.shape:
        raise InputError(f"{where}: ground mask is {mask.shape}, prediction is {prediction.shape}")
    if (camera.height, camera.width) != prediction.shape:
        raise InputError(
            f"{where}: camera is for {camera.width}x{camera.height}, prediction is "
            f"{prediction.shape[1]}x{prediction.shape[0]}"
        )
    if rng is None:
        rng = np.random.default_rng(0)
    if not (0 < threshold < 1):
        raise InputError(f"{where}: threshold must be in (0, 1), got {threshold}")

    ground_m, ground_ok = ground_plane_depth(camera, params.align_max_ground_depth_m)
    use = mask & ground_ok & prediction.valid
    rows, cols = np.nonzero(use)
    if len(rows) < params.align_min_ground_pixels:
        raise CalibrationError(
            f"{where}: only {len(rows)} usable ground pixels (road/sidewalk below the horizon, "
            f"within {params.align_max_ground_depth_m:g} m, with a valid prediction); "
            f"need {params.align_min_ground_pixels}"
        )
    if len(rows) > max_samples:
        pick = np.sort(rng.choice(len(rows), size=max_samples, replace=False))
        rows, cols = rows[pick], cols[pick]
    v = prediction.depth[rows, cols].astype(np.float64)
    g = ground_m[rows, cols].astype(np.float64)

    space, with_shift = _space_and_shift(prediction)
    A = _design(v, g, space, with_shift)
    p, _ = _ransac(A, threshold, iterations, rng)
    p, inliers = _irls(A, p, threshold)
    scale, shift = float(p[0]), float(p[1]) if with_shift else 0.0
    n = len(v)
    ratio = float(inliers.sum()) / n
    if not (np.isfinite(scale) and scale > 0) or ratio < params.align_min_inlier_ratio:
        raise CalibrationError(
            f"{where}: the ground explains only {100 * ratio:.0f} % of {n} ground pixels "
            f"(need {100 * params.align_min_inlier_ratio:.0f} %); the prediction does not fit a flat road"
        )
    fit_partial = AlignmentFit(scale, shift, ratio, 0.0, n, space)
    err = np.abs(fit_partial.apply(v[inliers]) - g[inliers])
    fit = AlignmentFit(scale, shift, ratio, float(np.median(err)), n, space)

    depth = fit.apply(prediction.depth)
    with np.errstate(invalid="ignore"):
        valid = prediction.valid & np.isfinite(depth) & (depth > 0) & (depth <= params.align_max_depth_m)
    depth_m = np.where(valid, depth, 0.0).astype(np.float32)
    log.info(
        "%s: scale %.4g shift %.4g (%s), %.0f %% inliers of %d, median error %.3f m",
        where,
        scale,
        shift,
        space,
        100 * ratio,
        n,
        fit.residual_m,
    )
    return fit, DepthMap(depth_m=depth_m, valid=valid, source=f"{prediction.name}:ground-aligned")
