"""Painted lane markings along the street, and the camera height their spacing measures.

Lane lines are bright, thin stripes on the road that run along the street, so in the image
they are straight lines through the street's vanishing point. On a road plane seen by a
camera at height ``h`` pitched by ``p`` (zero roll), the ground points of one image row lie
at one distance ``t = h / (sin p + cos p (v - c_y) / f)`` ahead; two lines ``W`` apart across
a street that runs at ``psi`` to the optical axis are ``W / cos psi`` apart along that row,
which the image shows as ``w(v) = f W / (t cos psi) = W cos p (v - v_h) / (h cos psi)``
pixels, ``v_h`` the horizon row. The separation grows linearly with the row, and its
slope ``k = dw/dv`` is the difference of the two lines' slopes ``du/dv``:

    ``h = W cos p / (k cos psi)``

independent of the focal length and of where the horizon is. ``W`` is a lane width, a
published distribution (:class:`~usdworld.parameters.CameraParams` ``lane_width_m``), so
the pairs are a cue to the camera height with the relative spread of lane widths.

Detection (:func:`find_lane_markings`): a white top-hat along each row (kernel a few
marking widths, growing with the row as the road nears) keeps bright stripes narrower than
it and drops kerbs, car bodies and sunlit road wider than it; only rows below the horizon,
outside the objects' boxes and, when given, on the road are used. Each row's runs of stripe
pixels as wide as a marking there, with plain and alike road on both flanks, give one
centre point. The centres vote (a Hough transform over the slope and the column at the
vanishing row) for lines passing near the street's vanishing point: dashed lines add up
along their line, shadows and cracks spread. The best-supported line is refitted as
``u = a + b v`` from its own points (so its slope does not depend on the vanishing point's
error), kept when it covers enough rows, and its points removed; then the next. Neighbouring
lines are paired left to right where two neighbouring pairs agree (:func:`lane_pairs`).

Frames: image pixels (u right, v down, origin at the top-left corner).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from usdworld.errors import CalibrationError
from usdworld.geometry.roll import deroll_points
from usdworld.geometry.vanishing import VanishingPoint
from usdworld.parameters.camera import DEFAULT_CAMERA, CameraParams


@dataclass(frozen=True)
class LaneLine:
    """One painted line along the street, ``u = a + b v`` in the image.

    Attributes:
        a: column at row 0, pixels.
        b: slope ``du/dv`` (1).
        b_sigma: standard error of ``b`` from the fit's residuals.
        v_min: highest row with stripe pixels on the line, pixels.
        v_max: lowest such row, pixels.
        n_rows: distinct rows with stripe pixels on it.
    """

    a: float
    b: float
    b_sigma: float
    v_min: float
    v_max: float
    n_rows: int

    def u_at(self, v: np.ndarray) -> np.ndarray:
        """(N,) float64 columns of the line at rows ``v`` ((N,) float64), pixels."""
        return self.a + self.b * np.asarray(v, dtype=np.float64)


@dataclass(frozen=True)
class LanePair:
    """Two neighbouring lines; their slope difference measures ``W cos p / (h cos psi)``.

    Attributes:
        left: the line further left below the horizon (smaller ``b``).
        right: its right neighbour.
        k: ``right.b - left.b`` (> 0), the growth of their separation per image row.
        k_sigma: standard error of ``k``.
    """

    left: LaneLine
    right: LaneLine
    k: float
    k_sigma: float


@dataclass(frozen=True)
class LaneMarkings:
    """The lane lines a photo shows and the neighbouring pairs among them (both may be empty).

    Attributes:
        lines: the lines, left to right.
        pairs: neighbouring pairs that a lane width can explain.
        vanishing_u: column of the street's vanishing point they were found through, pixels.
    """

    lines: tuple[LaneLine, ...]
    pairs: tuple[LanePair, ...]
    vanishing_u: float

    def height_m(self, lane_width_m: float) -> np.ndarray:
        """(P,) float64 camera height each pair implies for a level camera looking along the street."""
        return np.array([lane_width_m / p.k for p in self.pairs])


NO_MARKINGS = LaneMarkings((), (), 0.0)


def derolled_markings(
    markings: LaneMarkings, roll: float, center_px: np.ndarray, params: CameraParams = DEFAULT_CAMERA
) -> LaneMarkings:
    """The markings as a level camera would see them (:func:`usdworld.geometry.roll.deroll_points`
    of each line's ends and of the vanishing column), paired again.

    Args:
        markings: the lines found in the rolled photo.
        roll: the camera's roll, radians.
        center_px: (2,) float64 principal point, pixels.
        params: the pairing's lane width and heights.
    """
    if roll == 0.0 or not markings.lines:
        return markings
    lines = []
    for ln in markings.lines:
        v = np.array([ln.v_min, ln.v_max])
        (u0, v0), (u1, v1) = deroll_points(np.column_stack([ln.u_at(v), v]), roll, center_px)
        b = (u1 - u0) / (v1 - v0)
        top, bottom = float(min(v0, v1)), float(max(v0, v1))
        lines.append(LaneLine(float(u0 - b * v0), float(b), ln.b_sigma, top, bottom, ln.n_rows))
    lines.sort(key=lambda ln: ln.b)
    # the vanishing column moves with the turn; its row is not needed (the cue uses the column only)
    u_vp = float(deroll_points(np.array([[markings.vanishing_u, center_px[1]]]), roll, center_px)[0, 0])
    return LaneMarkings(tuple(lines), lane_pairs(lines, params), u_vp)


def _stripes(gray: np.ndarray, rows: np.ndarray, kernels: np.ndarray, params: CameraParams) -> np.ndarray:
    """(H, W) bool stripe pixels: white top-hat above ``lane_min_contrast`` on the given rows.

    Args:
        gray: (H, W) uint8 image.
        rows: (R,) int64 the rows to filter.
        kernels: (R,) int64 odd top-hat widths of those rows, pixels.
        params: the contrast threshold.
    """
    out = np.zeros(gray.shape, dtype=bool)
    for size in np.unique(kernels):
        band = rows[kernels == size]
        lo, hi = int(band.min()), int(band.max()) + 1
        element = cv2.getStructuringElement(cv2.MORPH_RECT, (int(size), 1))
        hat = cv2.morphologyEx(gray[lo:hi], cv2.MORPH_TOPHAT, element)
        mask = hat.astype(np.float64) >= params.lane_min_contrast
        sel = band - lo
        out[band] = mask[sel]
    return out


def _stripe_centres(
    mask: np.ndarray, gray: np.ndarray, px_per_m: np.ndarray, params: CameraParams
) -> tuple[np.ndarray, np.ndarray]:
    """Centres of the runs of stripe pixels along each row as wide as a marking there, on plain road.

    A run is kept when its width is within ``lane_run_slack`` of the markings' widths at its
    row (``px_per_m`` times ``lane_marking_width_m``): the road's grain gives runs of a pixel
    or two, sunlit patches and car parts wider ones. Paint lies on asphalt: the two flanks
    beside the run (each as wide as the run, half a run away) must be plain (grey-level
    spread under ``lane_flank_max_std``) and alike (means within ``lane_min_contrast``), which
    drops rails on gravel, paving joints, grass and a kerb's top (road one side, pavement
    the other).

    Args:
        mask: (H, W) bool stripe pixels.
        gray: (H, W) uint8 grey image.
        px_per_m: (H,) float64 lateral pixels per metre of road at each row.
        params: the marking widths and the slack.

    Returns:
        (u, v): (N,) float64 centre columns and rows, pixels.
    """
    padded = np.zeros((mask.shape[0], mask.shape[1] + 2), dtype=np.int8)
    padded[:, 1:-1] = mask
    step = np.diff(padded, axis=1)
    rs, cs = np.nonzero(step == 1)
    _, ce = np.nonzero(step == -1)  # same rows, same order: each run's start and end
    widths = (ce - cs).astype(np.float64)
    lo, hi = params.lane_marking_width_m
    slack = params.lane_run_slack
    ok = (widths >= px_per_m[rs] * lo / slack) & (widths <= px_per_m[rs] * hi * slack)
    rs, cs, ce, widths = rs[ok], cs[ok], ce[ok], widths[ok]
    g = gray.astype(np.float64)
    zero = np.zeros((g.shape[0], 1))
    s1 = np.hstack([zero, np.cumsum(g, axis=1)])
    s2 = np.hstack([zero, np.cumsum(g * g, axis=1)])
    n_cols = g.shape[1]
    w = np.maximum(widths, 3.0).astype(np.int64)
    gap = np.ceil(widths / 2).astype(np.int64)
    flank_ok = np.ones(len(rs), dtype=bool)
    means = []
    for a, b in ((cs - gap - w, cs - gap), (ce + gap, ce + gap + w)):
        inside = (a >= 0) & (b <= n_cols)
        a, b = np.clip(a, 0, n_cols), np.clip(b, 0, n_cols)
        n = np.maximum(b - a, 1)
        mean = (s1[rs, b] - s1[rs, a]) / n
        var = (s2[rs, b] - s2[rs, a]) / n - mean**2
        flank_ok &= inside & (np.sqrt(np.maximum(var, 0.0)) <= params.lane_flank_max_std)
        means.append(mean)
    flank_ok &= np.abs(means[0] - means[1]) <= params.lane_min_contrast
    cs, ce, rs = cs[flank_ok], ce[flank_ok], rs[flank_ok]
    return 0.5 * (cs + ce - 1).astype(np.float64), rs.astype(np.float64)


def _hough(
    u: np.ndarray, v: np.ndarray, u0: float, v0: float, width: int, params: CameraParams
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Votes of stripe centres for lines ``u = u_ref + b (v - v0)`` that pass within
    ``lane_vp_tol_fraction * width`` of the vanishing point ``(u0, v0)``.

    Args:
        u: (N,) float64 centre columns, pixels.
        v: (N,) float64 centre rows, pixels.
        u0: the vanishing point's column, pixels.
        v0: its row, pixels.
        width: image width, pixels.
        params: the angle step and the vanishing point's tolerance.

    Returns:
        votes: (T, U) int64 centres per (slope, column at the vanishing row) cell.
        slopes: (T,) float64 the slopes ``b`` (angles from the vertical, ``lane_vote_step_deg`` apart).
        u_ref: (U,) float64 the columns at the vanishing row, ``lane_fit_tol_px`` apart.
    """
    angles = np.radians(np.arange(-85.0, 85.0 + 1e-9, params.lane_vote_step_deg))
    slopes = np.tan(angles)
    reach = params.lane_vp_tol_fraction * width
    step = params.lane_fit_tol_px
    u_ref = np.arange(u0 - reach, u0 + reach + 1e-9, step)
    cell = np.round((u[None, :] + slopes[:, None] * (v0 - v[None, :]) - u_ref[0]) / step).astype(np.int64)
    ok = (cell >= 0) & (cell < len(u_ref))
    flat = (np.arange(len(slopes))[:, None] * len(u_ref) + cell)[ok]
    votes = np.bincount(flat, minlength=len(slopes) * len(u_ref)).reshape(len(slopes), len(u_ref))
    return votes, slopes, u_ref


def _line_fit(u: np.ndarray, v: np.ndarray) -> tuple[float, float]:
    """``(a, b)`` of the least-squares ``u = a + b v`` ((N,) float64 each), from exactly rounded sums
    (``math.fsum``) so that the result does not depend on how BLAS splits a long dot product."""
    n = len(u)
    mv, mu = math.fsum(v) / n, math.fsum(u) / n
    dv = v - mv
    b = math.fsum(dv * (u - mu)) / max(math.fsum(dv * dv), 1e-12)
    return mu - b * mv, b


def _fit_line(u: np.ndarray, v: np.ndarray, params: CameraParams) -> LaneLine | None:
    """Least-squares ``u = a + b v`` over stripe pixels, refitted twice without residuals above
    ``lane_fit_tol_px``; None when fewer than ``lane_min_rows`` distinct rows remain."""
    keep = np.ones(len(u), dtype=bool)
    for _ in range(3):
        if np.unique(v[keep]).size < params.lane_min_rows:
            return None
        coef = _line_fit(u[keep], v[keep])
        resid = u - (coef[0] + coef[1] * v)
        keep = np.abs(resid) <= params.lane_fit_tol_px
    rows = np.unique(v[keep])
    if rows.size < params.lane_min_rows:
        return None
    # the stripe's own width scatters its pixels about the centre line: the slope's error
    # counts one residual per row (the rows are the independent measurements), not per pixel
    vk, rk = v[keep], resid[keep]
    s2 = float(np.mean(rk**2)) + params.lane_edge_noise_px**2
    spread = float(np.sum((rows - rows.mean()) ** 2))
    b_sigma = math.sqrt(s2 / max(spread, 1e-9))
    return LaneLine(float(coef[0]), float(coef[1]), b_sigma, float(vk.min()), float(vk.max()), int(rows.size))


def find_lane_markings(
    rgb: np.ndarray,
    vanishing: VanishingPoint | None,
    exclude_boxes_px: np.ndarray,
    road_mask: np.ndarray | None = None,
    params: CameraParams = DEFAULT_CAMERA,
) -> LaneMarkings:
    """The painted lines along the street (module docstring); :data:`NO_MARKINGS` when none show.

    Args:
        rgb: (H, W, 3) uint8 photo.
        vanishing: the street's vanishing point (the lines pass through it); without one no
            lines are looked for.
        exclude_boxes_px: (N, 4) float64 ``xmin, ymin, xmax, ymax`` of objects standing on the
            road (cars, people), pixels: their bright parts are not paint.
        road_mask: (H, W) bool road pixels, or None (then every pixel below the horizon).
        params: widths, contrast, flanks, the vote's resolution and the support needed.

    Returns:
        The lines, left to right, and their neighbouring pairs.
    """
    if vanishing is None:
        return NO_MARKINGS
    height, width = rgb.shape[:2]
    gray = cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2GRAY)
    u0, v0 = vanishing.u, vanishing.v
    # rows far enough below the horizon that a marking is a few pixels wide
    # lateral pixels per metre of road at each row, whatever the focal length (module docstring)
    px_per_m = (np.arange(height) - v0) / params.height_prior_mean_m
    rows = np.nonzero(px_per_m * params.lane_marking_width_m[0] >= params.lane_min_stripe_px)[0]
    if rows.size < params.lane_min_rows:
        return NO_MARKINGS
    widest = px_per_m[rows] * params.lane_marking_width_m[1] * params.lane_kernel_factor
    # odd kernel widths on a ~20 % geometric ladder: a few bands, each filtered once
    ladder = np.exp(np.round(np.log(np.maximum(widest, 3.0)) / math.log(1.2)) * math.log(1.2))
    kernels = (2 * np.ceil(ladder / 2) + 1).astype(np.int64)
    mask = _stripes(gray, rows, kernels, params)
    if road_mask is not None:
        mask &= np.asarray(road_mask, dtype=bool)
    for x0, y0, x1, y1 in np.asarray(exclude_boxes_px, dtype=np.float64).reshape(-1, 4):
        pad = params.lane_box_margin_fraction * (x1 - x0)
        rows_box = slice(max(0, int(y0)), max(0, int(math.ceil(y1 + pad))))
        mask[rows_box, max(0, int(x0 - pad)) : max(0, int(math.ceil(x1 + pad)))] = False
    u, v = _stripe_centres(mask, gray, px_per_m, params)
    if v.size == 0:
        return NO_MARKINGS
    lines: list[LaneLine] = []
    free = np.ones(len(u), dtype=bool)
    while free.sum() >= params.lane_min_rows:
        votes, slopes, u_ref = _hough(u[free], v[free], u0, v0, width, params)
        t, j = np.unravel_index(int(np.argmax(votes)), votes.shape)
        if votes[t, j] < params.lane_min_rows:
            break
        near = free & (np.abs(u - (u_ref[j] + slopes[t] * (v - v0))) <= params.lane_fit_tol_px)
        line = _fit_line(u[near], v[near], params)
        free &= ~near
        if line is None or (line.v_max - line.v_min) < params.lane_min_extent_fraction * (height - v0):
            continue
        free &= np.abs(u - line.u_at(v)) > params.lane_fit_tol_px
        lines.append(line)
    lines.sort(key=lambda ln: ln.b)
    return LaneMarkings(tuple(lines), lane_pairs(lines, params), float(u0))


def lane_pairs(
    lines: list[LaneLine] | tuple[LaneLine, ...], params: CameraParams = DEFAULT_CAMERA
) -> tuple[LanePair, ...]:
    """Neighbouring lines (sorted by slope) that are one lane apart by the evidence of the photo:
    two neighbouring pairs (three lines) whose spacings agree, as the lanes of one road do, within
    ``lane_agreement_sigma`` combined ``lane_width_within_std_m`` spreads, and whose spacing a lane
    width and a camera height in ``params.height_range_m`` can explain. A lone pair (a kerb and a
    line, a rail and a line) says nothing about whether it is a lane, and is left out.

    Args:
        lines: the lines, any order.
        params: the lane widths, the agreement needed and the camera heights possible.
    """
    ordered = sorted(lines, key=lambda ln: ln.b)
    h_lo, h_hi = params.height_range_m
    candidates: list[LanePair | None] = []
    for left, right in zip(ordered[:-1], ordered[1:]):
        k = right.b - left.b
        ok = k > 0 and h_lo <= params.lane_width_m / k <= h_hi
        candidates.append(LanePair(left, right, k, math.hypot(left.b_sigma, right.b_sigma)) if ok else None)
    tol = params.lane_agreement_sigma * math.sqrt(2.0) * params.lane_width_within_std_m / params.lane_width_m
    keep = [False] * len(candidates)
    for i in range(len(candidates) - 1):
        a, b = candidates[i], candidates[i + 1]
        if a is not None and b is not None and abs(math.log(a.k / b.k)) <= tol:
            keep[i] = keep[i + 1] = True
    return tuple(p for p, kept in zip(candidates, keep) if kept and p is not None)


@dataclass(frozen=True)
class LaneWidthCue:
    """The lane pairs as a measurement of the camera height (module docstring).

    The lanes of one road share one width ``W``, normal in ``log W`` about ``log lane_width_m``
    with the published spread (``width_sigma_log``), integrated out on a grid. Given ``W``,
    each pair is a mixture: with probability ``inlier_fraction`` its lines are one lane apart
    and ``log k`` is normal about ``log(W cos p / (h cos psi))`` with the pair's own spread (its
    fit's, and lanes of one road differing a little); otherwise (a kerb, a rail, a parking or
    bus lane, a line missed between two) ``log k`` is uniform over the range the searched
    heights allow, so a wrong pair costs a near constant and does not pull the fit.

    Attributes:
        k: (P,) float64 each pair's separation growth per row.
        sigma_log: (P,) float64 each pair's spread in ``log k`` about the road's lane width.
        tan_psi_px: ``(u_vp - c_x) / f``, the street's vanishing column off the principal point;
            the street's angle to the camera's heading is ``psi = atan(tan_psi_px cos p)``.
        lane_width_m: the lane width's mean, metres.
        width_sigma_log: the lane width's spread in ``log W`` (about its relative spread).
        inlier_fraction: prior probability that a pair is one lane apart.
        log_range: width of the uniform outlier density in ``log k`` (``log(h_max / h_min)``).
    """

    k: np.ndarray
    sigma_log: np.ndarray
    tan_psi_px: float
    lane_width_m: float
    width_sigma_log: float
    inlier_fraction: float
    log_range: float

    def __post_init__(self) -> None:
        if np.shape(self.k) != np.shape(self.sigma_log) or not np.all(np.asarray(self.k) > 0):
            raise CalibrationError("lane-width cue: k must be positive and match sigma_log in length")
        if not (0.0 < self.inlier_fraction <= 1.0 and self.log_range > 0 and self.width_sigma_log > 0):
            raise CalibrationError(
                "lane-width cue: inlier_fraction must be in (0, 1], log_range and width_sigma_log > 0"
            )

    def __len__(self) -> int:
        return len(self.k)

    def cost(self, h: np.ndarray, pitch: np.ndarray) -> np.ndarray:
        """(G,) float64 negative log likelihood of the pairs (up to a constant) for candidate heights
        and pitches ((G,) float64 metres and radians), the lane width integrated out."""
        z = np.linspace(-3.0, 3.0, 25)  # the lane width's grid, in its sigmas
        log_w = np.log(self.lane_width_m) + self.width_sigma_log * z
        log_prior = -0.5 * z**2 - math.log(np.sum(np.exp(-0.5 * z**2)))
        # (G, 1, 1) + (1, Z, 1): log of the predicted k for each candidate and lane width
        base = (np.log(np.cos(pitch)) - np.log(np.asarray(h)) - np.log(self._cos_psi(pitch)))[:, None, None]
        sig = np.asarray(self.sigma_log)[None, None, :]
        r = (np.log(self.k)[None, None, :] - base - log_w[None, :, None]) / sig
        inlier = math.log(self.inlier_fraction) - 0.5 * r**2 - np.log(sig * math.sqrt(2 * math.pi))
        if self.inlier_fraction < 1.0:
            outlier = math.log(1.0 - self.inlier_fraction) - math.log(self.log_range)
            per_width = np.logaddexp(inlier, outlier).sum(axis=2)
        else:
            per_width = inlier.sum(axis=2)
        total = per_width + log_prior[None, :]
        top = total.max(axis=1, keepdims=True)
        return -(top[:, 0] + np.log(np.exp(total - top).sum(axis=1)))

    def _cos_psi(self, pitch: np.ndarray | float) -> np.ndarray:
        """cos of the street's angle to the camera's heading, for pitches ``pitch`` (radians)."""
        return 1.0 / np.sqrt(1.0 + (self.tan_psi_px * np.cos(pitch)) ** 2)

    def heights_m(self, pitch: float = 0.0) -> np.ndarray:
        """(P,) float64 the camera height each pair implies at the lane width's mean."""
        return self.lane_width_m * math.cos(pitch) / (np.asarray(self.k) * float(self._cos_psi(pitch)))


def lane_width_cue(
    markings: LaneMarkings, K: np.ndarray, params: CameraParams = DEFAULT_CAMERA
) -> LaneWidthCue | None:
    """The height cue of the markings' pairs for a camera matrix ``K`` ((3, 3) float64); None without pairs."""
    if not markings.pairs:
        return None
    k = np.array([p.k for p in markings.pairs])
    fit = np.array([p.k_sigma for p in markings.pairs]) / k
    sigma = np.sqrt((params.lane_width_within_std_m / params.lane_width_m) ** 2 + fit**2)
    h_lo, h_hi = params.height_range_m
    return LaneWidthCue(
        k,
        sigma,
        (markings.vanishing_u - float(K[0, 2])) / float(K[0, 0]),
        params.lane_width_m,
        params.lane_width_std_m / params.lane_width_m,
        params.lane_pair_inlier_fraction,
        math.log(h_hi / h_lo),
    )
