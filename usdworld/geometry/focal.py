"""The focal length of a photo without a camera file: cues, each with its uncertainty, fused.

Every cue is a measurement of ``log f`` (``f`` in pixels, square pixels, principal point
at the image centre) with a standard error:

* :func:`prior_cue`: what cameras usually have (a fraction of the image diagonal, from
  published phone and vehicle cameras; :class:`~usdworld.parameters.CameraParams`);
* an EXIF focal length (:mod:`usdworld.io.exif` reads it; :func:`exif_cue` wraps it);
* :func:`focal_from_orthogonal_vps`: two vanishing points of orthogonal directions,
  ``f^2 = -(v1 - c) . (v2 - c)`` (Caprile and Torre 1990; Hartley and Zisserman, 2nd ed.,
  section 8.8); :mod:`usdworld.geometry.vanishing` finds the street's and the vertical one;
* :func:`box_shape_cue`: vehicles of known size aligned with the street: the side of a
  car seen off the optical axis spans ``~ L (u - c_x) / (f h)`` pixels in a photo scaled
  by the ground contact, so the box widths across the image measure ``f`` once the rear
  widths and heights have measured the camera height.

:func:`fuse_focal` drops, one at a time, a cue inconsistent with the fusion of the others
beyond ``focal_outlier_sigma`` and combines the rest: by inverse variance in ``log f`` when
every cue is a Gaussian, else as the posterior of ``log f`` under the product of the cues'
likelihoods (the box shapes' is a profile likelihood, flat on one side where their widths
stop telling focal lengths apart, which a Gaussian summary would make symmetric).

Frames: image pixels (u right, v down); the object-shape model's camera frame is
OpenCV's (x right, y down, z forward), level, with the pitch as a shift of the horizon.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from usdworld.errors import CalibrationError
from usdworld.parameters.camera import DEFAULT_CAMERA, CameraParams


@dataclass(frozen=True)
class FocalCue:
    """One measurement of the focal length.

    Attributes:
        source: ``prior``, ``exif``, ``vanishing_points`` or ``box_shapes``.
        f_px: focal length, pixels.
        sigma_log: standard error of ``log f``.
        detail: what it was measured from, one phrase.
        profile_log_f: (M,) increasing ``log f`` grid of the cue's own log likelihood, or
            empty: then the cue is the Gaussian ``(log f_px, sigma_log)``.
        profile_log_lik: (M,) the log likelihood on that grid (its maximum 0). Outside the
            grid the likelihood is taken as flat at its end values (nothing was measured there).
            ``f_px`` and ``sigma_log`` are then its Laplace summary, used to test consistency.
    """

    source: str
    f_px: float
    sigma_log: float
    detail: str
    profile_log_f: tuple[float, ...] = field(default=(), compare=False)
    profile_log_lik: tuple[float, ...] = field(default=(), compare=False)

    def __post_init__(self) -> None:
        if not (np.isfinite(self.f_px) and self.f_px > 0):
            raise CalibrationError(f"focal cue '{self.source}': f must be a positive number of pixels, got {self.f_px}")
        if not (np.isfinite(self.sigma_log) and self.sigma_log > 0):
            raise CalibrationError(f"focal cue '{self.source}': sigma_log must be > 0, got {self.sigma_log}")
        grid, lik = np.asarray(self.profile_log_f, float), np.asarray(self.profile_log_lik, float)
        if len(grid) != len(lik) or (len(grid) and (len(grid) < 3 or not np.all(np.diff(grid) > 0))):
            raise CalibrationError(
                f"focal cue '{self.source}': the profile needs matching log f and log likelihood of "
                f">= 3 points, log f increasing; got {len(grid)} and {len(lik)}"
            )
        if not (np.all(np.isfinite(grid)) and np.all(np.isfinite(lik))):
            raise CalibrationError(f"focal cue '{self.source}': the profile must be finite")

    def log_likelihood(self, log_f: np.ndarray) -> np.ndarray:
        """(K,) float64 log likelihood of each ``log f`` in ``log_f`` ((K,) float64), up to a constant:
        the profile where the cue has one, else the Gaussian ``-(log f - log f_px)^2 / (2 sigma_log^2)``."""
        if self.profile_log_f:
            return np.interp(log_f, self.profile_log_f, self.profile_log_lik)
        return -0.5 * ((log_f - np.log(self.f_px)) / self.sigma_log) ** 2

    def describe(self) -> str:
        """``source f = 721 px +- 8 % (detail)``."""
        return f"{self.source} f = {self.f_px:.0f} px +- {100 * self.sigma_log:.0f} % ({self.detail})"


@dataclass(frozen=True)
class FocalEstimate:
    """The fused focal length and where it came from.

    Attributes:
        f_px: focal length, pixels.
        sigma_log: standard error of ``log f`` (about the relative error).
        used: the cues fused.
        dropped: the cues dropped as inconsistent with the others.
        tilt: (pitch, roll) radians the vanishing points imply at ``f_px``
            (:func:`usdworld.geometry.lateral.tilt_from_vanishing_points`), or None; reported,
            not used by the camera fit.
        tilt_source: which vanishing points gave the tilt, one phrase.
    """

    f_px: float
    sigma_log: float
    used: tuple[FocalCue, ...]
    dropped: tuple[FocalCue, ...] = ()
    tilt: tuple[float, float] | None = None
    tilt_source: str = ""

    @property
    def sources(self) -> tuple[str, ...]:
        """Sources of the cues fused."""
        return tuple(c.source for c in self.used)

    def describe(self) -> str:
        """One line: the result, each cue used and each dropped."""
        text = f"focal length {self.f_px:.0f} px +- {100 * self.sigma_log:.0f} % from " + "; ".join(
            c.describe() for c in self.used
        )
        if self.dropped:
            text += "; dropped as inconsistent: " + "; ".join(c.describe() for c in self.dropped)
        if self.tilt is not None:
            source = self.tilt_source or "the vanishing points"
            text += (
                f"; tilt from {source}: pitch {np.degrees(self.tilt[0]):.1f} deg, "
                f"roll {np.degrees(self.tilt[1]):.1f} deg (reported, not used)"
            )
        return text


def principal_point(width: int, height: int) -> np.ndarray:
    """(2,) float64 image centre ``(W/2, H/2)``, pixels (pixel centres at integers, edges at -0.5)."""
    return np.array([width / 2.0, height / 2.0])


def prior_cue(width: int, height: int, params: CameraParams = DEFAULT_CAMERA) -> FocalCue:
    """The prior: ``params.focal_prior_diag_ratio`` of the image diagonal, ``focal_prior_sigma_log`` in log f."""
    f = params.focal_prior_diag_ratio * float(np.hypot(width, height))
    diag_fov = 2 * np.degrees(np.arctan(0.5 / params.focal_prior_diag_ratio))
    return FocalCue("prior", f, params.focal_prior_sigma_log, f"typical camera, {diag_fov:.0f} deg diagonal field of view")


def exif_cue(f_px: float, detail: str, params: CameraParams = DEFAULT_CAMERA) -> FocalCue:
    """A focal length read from the photo's EXIF, pixels, with ``params.exif_sigma_log``."""
    return FocalCue("exif", f_px, params.exif_sigma_log, detail)


def fuse_focal(cues: list[FocalCue] | tuple[FocalCue, ...], params: CameraParams = DEFAULT_CAMERA) -> FocalEstimate:
    """Inverse-variance mean of the cues in log f (the posterior mean of log f when a cue has a
    profile likelihood), robust to one (or more) wrong cue.

    While two or more cues remain, each cue's leave-one-out discrepancy
    ``z_i = |log f_i - log f_(-i)| / sqrt(s_i^2 + s_(-i)^2)`` is computed against the
    fusion of the others; the cue with the largest ``z`` (the less certain one on a tie,
    as between two cues alone) is dropped when ``z > params.focal_outlier_sigma``.

    Args:
        cues: at least one cue.
        params: the outlier threshold.

    Returns:
        The fused estimate.

    Raises:
        CalibrationError: no cues.
    """
    if not cues:
        raise CalibrationError("focal length: no cues to fuse (the prior is always one)")
    used = list(cues)
    dropped: list[FocalCue] = []
    while len(used) >= 2:
        logs = np.log([c.f_px for c in used])
        w = 1.0 / np.array([c.sigma_log for c in used]) ** 2
        z = np.empty(len(used))
        for i in range(len(used)):
            others = np.arange(len(used)) != i
            mean_o = float(np.sum(w[others] * logs[others]) / np.sum(w[others]))
            var_o = 1.0 / float(np.sum(w[others]))
            z[i] = abs(logs[i] - mean_o) / np.sqrt(1.0 / w[i] + var_o)
        order = sorted(range(len(used)), key=lambda i: (-round(float(z[i]), 9), -used[i].sigma_log))
        worst = order[0]
        if z[worst] <= params.focal_outlier_sigma:
            break
        dropped.append(used.pop(worst))
    logs = np.log([c.f_px for c in used])
    w = 1.0 / np.array([c.sigma_log for c in used]) ** 2
    mean = float(np.sum(w * logs) / np.sum(w))
    sigma = float(1.0 / np.sqrt(np.sum(w)))
    if any(c.profile_log_f for c in used):
        mean, sigma = _posterior_log_f(used, mean, sigma, params)
    return FocalEstimate(float(np.exp(mean)), sigma, tuple(used), tuple(dropped))


def _posterior_log_f(
    cues: list[FocalCue], mean: float, sigma: float, params: CameraParams
) -> tuple[float, float]:
    """Mean and standard deviation of ``log f`` under the product of the cues' likelihoods.

    Summed on ``params.focal_posterior_steps`` points over ``params.focal_posterior_half_width``
    Gaussian-fusion sigmas (at least the widest cue's) either side of the Gaussian fusion
    (``mean``, ``sigma``), so a profile's skew (a flat side where the boxes stop telling focal
    lengths apart) is kept instead of its Laplace summary's symmetric guess.
    """
    half = params.focal_posterior_half_width * max(sigma, max(c.sigma_log for c in cues))
    grid = np.linspace(mean - half, mean + half, params.focal_posterior_steps)
    log_post = np.sum([c.log_likelihood(grid) for c in cues], axis=0)
    w = np.exp(log_post - log_post.max())
    w /= w.sum()
    post_mean = float(np.sum(w * grid))
    return post_mean, float(np.sqrt(np.sum(w * (grid - post_mean) ** 2)))


def focal_from_orthogonal_vps(vp1_px: np.ndarray, vp2_px: np.ndarray, center_px: np.ndarray) -> float | None:
    """Focal length from the vanishing points of two orthogonal directions.

    With square pixels and the principal point ``c``, the rays ``(v - c, f)`` of two
    orthogonal directions have zero dot product: ``f^2 = -(v1 - c) . (v2 - c)``.

    Args:
        vp1_px: (2,) float64 first vanishing point, pixels.
        vp2_px: (2,) float64 second, pixels.
        center_px: (2,) float64 principal point, pixels.

    Returns:
        f in pixels, or None when the dot product is not negative (the points are not
        the images of orthogonal directions under any focal length).
    """
    f2 = -float(np.dot(np.asarray(vp1_px) - center_px, np.asarray(vp2_px) - center_px))
    return float(np.sqrt(f2)) if f2 > 0 else None


@dataclass(frozen=True)
class BoxShapes:
    """Vehicles whose whole 2D box is in view, with their class size (the object-shape cue).

    Attributes:
        box_px: (N, 4) float64 ``xmin, ymin, xmax, ymax`` pixels.
        size_m: (N, 3) float64 class length, width, height, metres.
        height_std_m: (N,) float64 spread of the height, metres.
    """

    box_px: np.ndarray
    size_m: np.ndarray
    height_std_m: np.ndarray

    def __post_init__(self) -> None:
        n = len(self.box_px)
        if np.shape(self.box_px) != (n, 4) or np.shape(self.size_m) != (n, 3) or np.shape(self.height_std_m) != (n,):
            raise CalibrationError("box shapes: box_px must be (N, 4), size_m (N, 3) and height_std_m (N,)")

    def __len__(self) -> int:
        return len(self.box_px)


def project_street_boxes(
    f: np.ndarray,
    h: np.ndarray,
    v_h: np.ndarray,
    street_yaw: np.ndarray,
    center_px: np.ndarray,
    shapes: BoxShapes,
    iterations: int = 4,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Predicted widths and top rows of street-aligned boxes placed to fit the bottom row and centre column.

    Each vehicle is a box of its class size standing on the ground, its length along the
    street (yaw ``street_yaw`` about the camera's vertical axis, 0 = the optical axis). For
    each candidate camera (focal ``f``, height ``h``, horizon row ``v_h``; a level camera
    whose pitch shifts the horizon) the box is moved so that its nearest bottom corner
    projects to the box's bottom row and its projected centre column to the box's; its
    projected width and top row are returned.

    Args:
        f, h, v_h, street_yaw: (G,) float64 candidates (pixels, metres, pixels, radians).
        center_px: (2,) float64 principal point.
        shapes: the N vehicles.
        iterations: fixed-point steps of the lateral position.

    Returns:
        width_px: (G, N) predicted box widths (NaN where the bottom is at or above the horizon).
        top_v: (G, N) predicted top rows.
        depth: (G, N) depth of the box centre, metres.
    """
    cx = center_px[0]
    f, h, v_h = f[:, None], h[:, None], v_h[:, None]
    sy, cyaw = np.sin(street_yaw)[:, None, None], np.cos(street_yaw)[:, None, None]
    L, W, H = (shapes.size_m[None, :, k] for k in range(3))
    box = shapes.box_px[None]
    # footprint corner offsets (G, N, 4) in x and z: +-L/2 along (sin, cos), +-W/2 along (cos, -sin)
    sl = np.array([1, 1, -1, -1])[None, None, :] * (L / 2)[..., None]
    sw = np.array([1, -1, 1, -1])[None, None, :] * (W / 2)[..., None]
    ox = sl * sy + sw * cyaw
    oz = sl * cyaw - sw * sy
    with np.errstate(divide="ignore", invalid="ignore"):
        dv = box[..., 3] - v_h
        z_near = np.where(dv > 0.5, f * h / dv, np.nan)
        Z = z_near - oz.min(axis=2)
        u_mid = 0.5 * (box[..., 0] + box[..., 2])
        X = (u_mid - cx) / f * Z
        for _ in range(iterations):
            u = cx + f[..., None] * (X[..., None] + ox) / (Z[..., None] + oz)
            X = X - (0.5 * (u.min(axis=2) + u.max(axis=2)) - u_mid) * Z / f
        zc = Z[..., None] + oz
        u = cx + f[..., None] * (X[..., None] + ox) / zc
        width = u.max(axis=2) - u.min(axis=2)
        top_v = v_h + f * ((h - H)[..., None] / zc).min(axis=2)
    return width, top_v, Z


def box_shape_profile(
    width: int,
    height: int,
    shapes: BoxShapes,
    street_u: float | None = None,
    horizon: tuple[float, float] | None = None,
    params: CameraParams = DEFAULT_CAMERA,
) -> tuple[np.ndarray, np.ndarray]:
    """The profile log likelihood of ``log f`` the vehicles' box shapes give (module docstring).

    A grid over (log f, camera height, pitch) scores the Cauchy residuals of every
    vehicle's predicted box width and top row (spreads: the class size's, relative
    ``params.shape_length_rel_std`` for length and width, ``params.shape_yaw_std_deg`` of turn off the street, ``height_std_m`` for height,
    plus ``params.edge_noise_px``; each vehicle along the street or, with probability
    ``params.shape_cross_fraction``, across it), with the camera-height and pitch priors and,
    when given, the horizon row. The profile keeps, for each focal length, the best height
    and horizon row (the focal prior is fused separately).

    Args:
        width: image width, pixels.
        height: image height, pixels.
        shapes: the vehicles (whole boxes in view), at least one.
        street_u: column of the street's vanishing point (the vehicles' direction), or None
            (the optical axis).
        horizon: (row, sigma) of the horizon measured otherwise (the street's vanishing
            point), or None.
        params: priors, spreads and grid.

    Returns:
        log_f: (M,) float64 increasing grid of ``log f`` (``params.shape_focal_range`` of the diagonal).
        log_lik: (M,) float64 the profile log likelihood there, its maximum 0.
    """
    c = principal_point(width, height)
    diag = float(np.hypot(width, height))
    n_f, n_h, n_p = params.shape_grid
    fs = diag * np.exp(np.linspace(*np.log(params.shape_focal_range), n_f))
    mean_h, std_h = params.height_prior_m
    hs = np.linspace(max(params.height_range_m[0], mean_h - 3 * std_h), mean_h + 3 * std_h, n_h)
    # horizon rows on a uniform pixel grid (not pitch angles: summing over angles would give
    # short focal lengths more horizon candidates per pixel and so more likelihood)
    half = np.tan(np.radians(2 * params.pitch_prior_std_deg)) * 1.5 * prior_cue(width, height, params).f_px
    rows = c[1] + np.linspace(-half, half, n_p)
    F, Hc, v_h = (a.ravel() for a in np.meshgrid(fs, hs, rows, indexing="ij"))
    P = np.arctan((c[1] - v_h) / F)
    yaw = np.arctan((street_u - c[0]) / F) if street_u is not None else np.zeros_like(F)
    # Each vehicle runs along the street or, with probability shape_cross_fraction, across it (a
    # crossing or turning vehicle, one parked across): a mixture per vehicle, so that a wide box
    # across the street does not read as a short focal length.
    along = _shape_costs(F, Hc, v_h, yaw, c, shapes, params)
    if params.shape_cross_fraction > 0:
        across = _shape_costs(F, Hc, v_h, yaw + np.pi / 2, c, shapes, params)
        p_cross = params.shape_cross_fraction
        data = -np.logaddexp(np.log1p(-p_cross) - along, np.log(p_cross) - across)
    else:
        data = along
    cost = data.sum(axis=1) + 0.5 * ((Hc - mean_h) / std_h) ** 2 + 0.5 * (np.degrees(P) / params.pitch_prior_std_deg) ** 2
    if horizon is not None:
        cost += np.log1p(((v_h - horizon[0]) / horizon[1]) ** 2)
    log_lik = -(cost - cost.min()).reshape(n_f, n_h * n_p).min(axis=1)
    return np.log(fs), log_lik


def box_shape_cue(
    width: int,
    height: int,
    shapes: BoxShapes,
    street_u: float | None = None,
    horizon: tuple[float, float] | None = None,
    params: CameraParams = DEFAULT_CAMERA,
) -> FocalCue | None:
    """The focal length the vehicles' box shapes measure: :func:`box_shape_profile` as a cue.

    The profile likelihood of log f is the cue: :func:`fuse_focal` multiplies it with the
    other cues' likelihoods, and its mode and curvature (a Laplace summary) are the ``f_px``
    and ``sigma_log`` its consistency with them is tested by. The arguments are
    :func:`box_shape_profile`'s; ``shapes`` may hold fewer than ``params.shape_min_objects``.

    Returns:
        The cue, or None with fewer than ``params.shape_min_objects`` vehicles.
    """
    if len(shapes) < params.shape_min_objects:
        return None
    logf, log_lik = box_shape_profile(width, height, shapes, street_u, horizon, params)
    n_f = len(logf)
    # The profile's mode and curvature (a Laplace approximation). Moments over the bounded
    # grid would pull a weak cue towards the grid's middle, and a marginal over the nuisance
    # parameters weighs focal lengths by how many of them fit; the profile's mode and
    # curvature do neither, and a flat profile shows as a large sigma.
    k = int(np.argmax(log_lik))
    if k < 2 or k > n_f - 3:
        return None  # no maximum inside the searched range
    near = np.zeros(n_f, dtype=bool)
    near[k - 2 : k + 3] = True  # the mode and two grid steps each side
    near |= log_lik >= log_lik[k] - 2.0  # and all within two log-units (about two sigmas)
    a, b, _ = np.polyfit(logf[near], log_lik[near], 2)
    if a >= 0:
        return None
    mean = float(np.clip(-b / (2 * a), logf[0], logf[-1]))
    sigma = float(np.sqrt(-1.0 / (2 * a)))
    if sigma > params.focal_max_sigma_log:
        return None  # the shapes add (almost) nothing to the prior
    sigma = max(sigma, params.focal_min_sigma_log)
    return FocalCue(
        "box_shapes",
        float(np.exp(mean)),
        sigma,
        f"{len(shapes)} vehicle box(es) of known size along the street",
        tuple(float(x) for x in logf),
        tuple(float(x) for x in log_lik),
    )


def _shape_costs(
    F: np.ndarray,
    Hc: np.ndarray,
    v_h: np.ndarray,
    yaw: np.ndarray,
    c: np.ndarray,
    shapes: BoxShapes,
    params: CameraParams,
) -> np.ndarray:
    """(G, N) float64 negative log density of each vehicle's box width and top row under each
    candidate camera (``F``, ``Hc``, ``v_h``: (G,) focal px, height m, horizon row px), its length
    along ``yaw`` ((G,) radians about the camera's vertical): Cauchy residuals with their log spreads."""
    w_pred, top_pred, depth = project_street_boxes(F, Hc, v_h, yaw, c, shapes)
    w_meas = shapes.box_px[:, 2] - shapes.box_px[:, 0]
    # a vehicle turned by d_yaw from its direction shows d_yaw * L more or less of its side
    # (f / Z px per metre)
    with np.errstate(invalid="ignore", divide="ignore"):
        turn_px = F[:, None] * shapes.size_m[None, :, 0] * np.sin(np.radians(params.shape_yaw_std_deg)) / depth
    sig_w = np.sqrt((params.shape_length_rel_std * w_pred) ** 2 + turn_px**2 + params.edge_noise_px**2)
    with np.errstate(invalid="ignore", divide="ignore"):
        sig_t = np.hypot(F[:, None] * shapes.height_std_m[None, :] / np.maximum(depth, 0.1), params.edge_noise_px)
        rw = (w_pred - w_meas[None, :]) / sig_w
        rt = (top_pred - shapes.box_px[None, :, 1]) / sig_t
    # Cauchy negative log densities, with log sigma: the spreads grow with the focal length,
    # and without their normalisation a longer focal length would explain misfits for free.
    with np.errstate(invalid="ignore", divide="ignore"):
        data = np.where(np.isfinite(rw), np.log1p(rw**2) + np.log(sig_w), params.unprojectable_cost)
        data += np.where(np.isfinite(rt), np.log1p(rt**2) + np.log(sig_t), params.unprojectable_cost)
    return data
