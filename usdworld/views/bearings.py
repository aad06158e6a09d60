"""A standing point triangulated from bearings seen by a moving camera, its depth prior counted once (pure numpy).

A drive's camera sees a standing trunk (tree, pole, sign) from a new place in every frame.
Its single-view depth errs by a share that the frames repeat (the object's size or contact
misjudged once for all), its bearing (the column of its trunk's base) does not, so the
point is where the rays cross (:func:`bearing_triangulation`); :mod:`usdworld.views.drive`
places a drive's standing trunks so.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from usdworld.parameters.views import ViewsParams
from usdworld.views.fusion import Observation

#: Iterations of the bearing triangulation's reweighting: Huber first (from the least-squares
#: start it leans on the bulk of the rays), then Cauchy until the weights settle (a frame that saw
#: another point fades); at most twice _MAX_ITERATIONS in all.
_HUBER_ITERATIONS = 5
_MAX_ITERATIONS = 60


def _huber(r: np.ndarray) -> np.ndarray:
    """(N,) Huber weights of (N,) residuals in units of the weight's scale."""
    return np.minimum(1.0, 1.0 / np.maximum(r, 1e-12))


def _cauchy(r: np.ndarray) -> np.ndarray:
    """(N,) Cauchy weights of (N,) residuals in units of the weight's scale."""
    return 1.0 / (1.0 + r * r)


def bearing_sigmas(members: Sequence[Observation], params: ViewsParams) -> np.ndarray:
    """(N,) across-ray standard deviations of the observations' bearings, metres.

    ``bearing_sigma_rad`` times the observed range, at least ``bearing_sigma_min_m``; an
    object cut by the image's left or right border (its contact's column is the cut's, not
    the trunk's) adds ``cut_sigma_share`` of its larger footprint extent, as the fusion's
    lateral spread does. A cut at the top or bottom leaves the trunk's column where it is.
    """
    out = []
    for o in members:
        r = float(np.linalg.norm(o.placement.contact_world[:2] - o.camera_ground))
        sigma = max(params.bearing_sigma_rad * r, params.bearing_sigma_min_m)
        if {"left", "right"} & set(o.placement.obj.cut_sides):
            sigma += params.cut_sigma_share * float(max(o.placement.size_m[0], o.placement.size_m[1]))
        out.append(sigma)
    return np.array(out, dtype=np.float64)


def bearing_triangulation(
    contacts: np.ndarray,
    cameras: np.ndarray,
    sigmas: np.ndarray,
    prior_xy: np.ndarray,
    prior_cov: np.ndarray,
    params: ViewsParams,
) -> tuple[np.ndarray, np.ndarray]:
    """(2,) position and (2, 2) covariance of a standing point from its frames' bearings and one depth.

    A moving camera sees a standing trunk from a new place in every frame. Its single-view
    depth errs by a share that the frames repeat (the object's size or contact misjudged
    once for all), its bearing does not: the point is where the rays cross. Each observation
    gives the line from its camera through its contact; the estimate minimises the squared
    distances across those lines (each in :func:`bearing_sigmas`, weighted by a Cauchy
    weight of scale ``bearing_outlier_scale`` so that a frame that saw another point counts
    for little) plus the depth prior counted once: ``prior_xy`` with ``prior_cov``'s
    variance along the mean viewing direction (what the depth cues know, floored for their
    shared error: the drive's standing estimate). Where the rays are nearly parallel (a far
    object over a short baseline) they fix nothing along the ray and the depth prior
    decides; where they cross at wide angles the bearings do.

    Args:
        contacts: (N, 2) float64 the observations' ground contacts in the world, metres.
        cameras: (N, 2) float64 the ground points of the cameras that made them, metres.
        sigmas: (N,) float64 their bearings' across-ray standard deviations, metres.
        prior_xy: (2,) float64 the depth prior's position, metres.
        prior_cov: (2, 2) float64 its covariance, metres squared.
        params: ``bearing_outlier_scale``.

    Returns:
        The position (metres) and its covariance (metres squared).
    """
    z = np.asarray(contacts, dtype=np.float64)
    cams = np.asarray(cameras, dtype=np.float64)
    sigma = np.asarray(sigmas, dtype=np.float64)
    rays = z - cams
    rays = rays / np.maximum(np.linalg.norm(rays, axis=1, keepdims=True), 1e-9)
    normals = np.c_[-rays[:, 1], rays[:, 0]]
    offsets = np.einsum("ki,ki->k", normals, cams)  # each line: normal . x = offset
    u = rays.mean(axis=0)
    u = u / max(float(np.linalg.norm(u)), 1e-9)
    prior_info = np.outer(u, u) / max(float(u @ prior_cov @ u), 1e-12)
    prior_vec = prior_info @ np.asarray(prior_xy, dtype=np.float64)
    scale = params.bearing_outlier_scale
    weights = np.ones(len(z))
    info = prior_info
    xy = np.asarray(prior_xy, dtype=np.float64)
    for it in range(2 * _MAX_ITERATIONS):
        w = weights / sigma**2
        info = np.einsum("k,ki,kj->ij", w, normals, normals) + prior_info
        xy = np.linalg.solve(info, np.einsum("k,ki,k->i", w, normals, offsets) + prior_vec)
        r = np.abs(normals @ xy - offsets) / sigma / scale
        new = _huber(r) if it < _HUBER_ITERATIONS else _cauchy(r)
        if it >= _HUBER_ITERATIONS and np.allclose(new, weights, atol=1e-6):
            break
        weights = new
    return xy, np.linalg.inv(info)
