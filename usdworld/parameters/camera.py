"""Tuned numbers of the camera stage (see :mod:`usdworld.parameters.base` for the field conventions).

The camera stage is :mod:`usdworld.geometry.estimate` (height and pitch from objects of known
height, the road's top row and the horizon) and :mod:`usdworld.geometry.vanishing` (the
street's vanishing point from the photo's line segments).
"""

from __future__ import annotations

from dataclasses import dataclass

from usdworld.parameters.base import param

_KITTI = "tuned: KITTI dev frames, median depth error 7.3 % -> 3.9 % (commit 81f24f0)"


@dataclass(frozen=True)
class CameraParams:
    """Thresholds of the camera stage; each field documents its unit, meaning and origin."""

    # --- priors and noise of the estimate (geometry/estimate.py) ---
    default_hfov_deg: float = param(
        60.0,
        "deg",
        "Horizontal field of view assumed when no intrinsics are given.",
        "convention: a typical dash or phone camera's field of view (commit 07357ff)",
    )
    height_prior_mean_m: float = param(
        1.5,
        "m",
        "Prior mean of a vehicle camera's height above the road; the height used where nothing measures it.",
        "published: KITTI 1.65 m (Geiger et al. 2012, 'Are we ready for autonomous driving?'), "
        "nuScenes about 1.5 m (Caesar et al. 2020), Cityscapes 1.22 m (Cordts et al. 2016)",
    )
    height_prior_std_m: float = param(
        0.3,
        "m",
        "Prior spread of the camera height.",
        "published: the spread of the datasets' heights above (1.22-1.65 m)",
    )
    pitch_prior_std_deg: float = param(
        3.0, "deg", "Prior spread of the camera pitch around level.", "convention: a forward-looking vehicle camera"
    )
    edge_noise_px: float = param(
        1.5,
        "px",
        "Pixel noise of a box's or mask's top edge, added to the class-height spread of each object's residual.",
        "convention: about one pixel of labelling plus one of quantisation (commit 07357ff)",
    )
    road_top_sigma_px: float = param(
        2.0,
        "px",
        "Softness of the bound that the road's top row puts on the horizon (the horizon lies above it).",
        "convention: a pixel or two of label noise at the road's far end (commit 07357ff)",
    )
    unprojectable_cost: float = param(
        10.0,
        "1",
        "Cost of an object whose contact is above a candidate horizon (no predicted top): a Cauchy "
        "residual of about e^10 sigma, an outlier that still counts against the candidate.",
        "convention: chosen with the code (commit 07357ff)",
    )
    # --- the search grid ---
    height_range_m: tuple[float, float] = param(
        (0.5, 4.0), "m", "Camera heights searched.", "convention: any car, van or handheld camera"
    )
    pitch_range_deg: tuple[float, float] = param(
        (-15.0, 15.0), "deg", "Camera pitches searched.", "convention: five sigmas of the pitch prior"
    )
    search_step_height_m: float = param(
        0.05,
        "m",
        "Coarsest height step of the coarse-to-fine search (three levels, each ten times finer).",
        "convention: resolution only (commit 07357ff)",
    )
    search_step_pitch_deg: float = param(
        0.25,
        "deg",
        "Coarsest pitch step of the coarse-to-fine search.",
        "convention: resolution only (commit 07357ff)",
    )
    moment_half_height_m: float = param(
        0.8, "m", "Half width in height of the grid the posterior mean is summed over.", _KITTI
    )
    moment_step_height_m: float = param(0.01, "m", "Height step of that grid.", _KITTI)
    moment_half_pitch_deg: float = param(
        4.0, "deg", "Half width in pitch of the grid the posterior mean is summed over.", _KITTI
    )
    moment_step_pitch_deg: float = param(0.05, "deg", "Pitch step of that grid.", _KITTI)
    # --- the street's vanishing point (geometry/vanishing.py) ---
    vp_max_width_px: int = param(
        1280,
        "px",
        "Wider photos are shrunk to this width before line-segment detection.",
        "convention: speed only; LSD finds the street's long lines at this size",
    )
    vp_min_length_fraction: float = param(
        0.025, "fraction", "Shortest segment used, as a fraction of the image width.", _KITTI
    )
    vp_min_length_px: float = param(15.0, "px", "Shortest segment used, pixels.", _KITTI)
    vp_min_slant_deg: float = param(
        8.0,
        "deg",
        "Segments closer than this to horizontal or vertical are ignored: they belong to lateral or "
        "upright structure, not to lines along the street.",
        _KITTI,
    )
    vp_angle_tol_deg: float = param(
        1.5, "deg", "A segment supports a point when its direction is within this of the point's.", _KITTI
    )
    vp_trials: int = param(600, "count", "RANSAC pairs of segments tried.", _KITTI)
    vp_min_inliers: int = param(8, "count", "Fewest segments supporting the vanishing point.", _KITTI)
    vp_min_per_side: int = param(
        2,
        "count",
        "Fewest supporting segments on each side of the point (one facade or fence does not decide it).",
        _KITTI,
    )
    road_slope_sigma_deg: float = param(
        1.0,
        "deg",
        "Spread of the road's slope against the camera's ground plane: a street that climbs or falls "
        "moves its vanishing point off the horizon of the ground under the car.",
        _KITTI,
    )

    @property
    def height_prior_m(self) -> tuple[float, float]:
        """(mean, spread) of the camera-height prior, metres."""
        return (self.height_prior_mean_m, self.height_prior_std_m)


#: The defaults (the default argument of the camera stage's public functions).
DEFAULT_CAMERA = CameraParams()
