"""Tuned numbers of the camera stage (see :mod:`usdworld.parameters.base` for the field conventions).

The camera stage is :mod:`usdworld.geometry.estimate` (height and pitch from objects of known
height, the road's top row and the horizon), :mod:`usdworld.geometry.vanishing` (the
street's and the vertical vanishing points from the photo's line segments) and
:mod:`usdworld.geometry.focal` (the focal length without a camera file: prior, EXIF,
vanishing points and vehicle box shapes, fused).
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
        "Horizontal field of view assumed for cutting facades before the camera is estimated, when no "
        "intrinsics are given (layout/camera_cues.street_view); the camera itself uses the focal-length "
        "cues and prior below.",
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
    plane_height_sigma_m: float = param(
        0.14,
        "m",
        "Uncertainty of the camera height a given road plane (a KITTI planes file) says, as a statement "
        "about the road under the objects: the plane is fitted round the car, and the road one or two "
        "lanes over lies higher or lower across its crossfall. The plane is a Gaussian prior on the "
        "height, fused with the objects' top rows (geometry.estimate.PosePrior), not a fixed height.",
        "published: road crossfall 1.5-2.5 % (AASHTO, A Policy on Geometric Design of Highways and "
        "Streets, 2018, sec. 4.2.2): 2 % across two 3.5 m lanes",
    )
    plane_pitch_sigma_deg: float = param(
        0.573,
        "deg",
        "Uncertainty of the pitch a given road plane says, as a statement about the road under the "
        "objects ahead: a road may change grade without a vertical curve, which the plane fitted round "
        "the car does not see (fused as plane_height_sigma_m).",
        "published: grade changes of up to 1 % without a vertical curve at design speeds up to 45 mph "
        "(TxDOT Roadway Design Manual, sec. 4.8.3): atan(0.01)",
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
    max_fit_objects: int = param(
        160,
        "count",
        "Most objects the height/pitch posterior is evaluated on; above it that many are taken evenly "
        "spread over their contact rows (ranges). The posterior costs (grid points x "
        "objects); beyond this count more objects no longer make the estimate better.",
        "geometry: the posterior's height spread falls as about 0.36 m / sqrt(N) (1.65 m camera, cars "
        "5-40 m ahead with the 0.12 m class-height spread; measured 0.114 m at 10, 0.034 m at 150, "
        "0.012 m at 1,000 objects); at N = 165 it reaches 0.028 m, the 1.7 % systematic error of the car "
        "height mean itself (prior 1.5 m vs KITTI's 1.526 m Car label mean), which no number of cars averages out",
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

    # --- the focal length when no camera file gives it (geometry/focal.py, io/exif.py) ---
    focal_prior_diag_ratio: float = param(
        0.62,
        "1",
        "Prior focal length as a fraction of the image diagonal (the centre of the prior, in log f). "
        "0.62 is a 27 mm 35 mm-equivalent lens (27 / 43.27 mm diagonal), between the published cameras: "
        "phone main cameras 23-26 mm equivalent (0.53-0.60) and KITTI 0.56 below it, nuScenes CAM_FRONT "
        "0.69 and Cityscapes 0.99 above (KITTI reads +11.5 % long with this prior alone, nuScenes -10 %); "
        "wide dash cameras (120-140 deg diagonal) lie near 0.2-0.3, 2-4 sigma below.",
        "published: Apple iPhone 12-15 and Samsung Galaxy S21-S24 main-camera specifications (23-26 mm "
        "equivalent); KITTI P2 (Geiger et al. 2013), nuScenes CAM_FRONT (Caesar et al. 2020), Cityscapes "
        "(Cordts et al. 2016) calibrations",
    )
    focal_prior_sigma_log: float = param(
        0.3,
        "1 (log f)",
        "Spread of that prior in log focal length (one sigma: x0.74 .. x1.35, covering 0.46-0.84 of the diagonal).",
        "published: the spread of the cameras above (log std 0.27 over KITTI, nuScenes, Cityscapes, phones)",
    )
    exif_sigma_log: float = param(
        0.03,
        "1 (log f)",
        "Spread of a focal length read from EXIF: rounding of the 35 mm-equivalent tag to whole millimetres "
        "and crops the tag does not know about.",
        "convention: 1 mm in 27 mm (4 %) rounding, about one sigma",
    )
    focal_outlier_sigma: float = param(
        3.0,
        "sigma",
        "A focal cue further than this from the fusion of the others (their combined sigma) is dropped.",
        "convention: three sigmas",
    )
    focal_min_sigma_log: float = param(
        0.05,
        "1 (log f)",
        "Smallest spread a cue measured from the photo (vanishing points, object shapes) may claim.",
        "convention: model error of a level-camera, street-aligned model (5 %)",
    )
    focal_max_sigma_log: float = param(
        1.0,
        "1 (log f)",
        "A photo's cue less certain than this (x2.7 either way) is not a measurement and is left out.",
        "convention: weaker than the prior by a factor of three",
    )
    focal_posterior_half_width: float = param(
        6.0,
        "sigma",
        "Half-width of the log f grid on which a cue's profile likelihood is multiplied with the other cues "
        "(in the widest used cue's sigmas, about the Gaussian fusion).",
        "convention: six sigmas hold all but 2e-9 of a Gaussian's mass",
    )
    focal_posterior_steps: int = param(
        1201, "count", "Points of that log f grid.", "convention: resolution only (0.01 sigma steps)"
    )
    principal_point_sigma_fraction: float = param(
        0.014,
        "fraction of the image diagonal",
        "Spread, per axis, of the true principal point around the image centre that every build without "
        "intrinsics assumes; it enters the vanishing-point focal cue's spread "
        "(f^2 = -(v1 - c).(v2 - c) moves by (v1 + v2 - 2c).dc).",
        "published: the root mean square of the principal-point offsets of KITTI P2 (11.4, 14.6 px of a "
        "1297 px diagonal: 0.9 %, 1.1 %; Geiger et al. 2013) and nuScenes CAM_FRONT (16.3, 41.5 px of "
        "1836 px: 0.9 %, 2.3 %; Caesar et al. 2020) calibrations",
    )
    vertical_max_tilt_deg: float = param(
        20.0,
        "deg",
        "Segments within this of the image vertical may belong to upright structure (the vertical vanishing point).",
        "geometry: a camera pitched or rolled by up to about 15 deg tilts verticals off the image's by less than this",
    )
    segment_end_noise_px: float = param(
        1.0,
        "px",
        "Standard error of a line segment's endpoint across the segment, in the lateral vanishing point's "
        "likelihood (a 40 px segment's direction is then known to about 2 deg).",
        "convention: about one pixel of edge localisation at the detection scale (LSD's gradients use 2 x 2 "
        "pixel neighbourhoods; von Gioi et al. 2012, IPOL)",
    )
    lateral_max_slant_deg: float = param(
        30.0,
        "deg",
        "Segments within this of the image horizontal (and not pointing at the street's vanishing point) may "
        "run across the street (crossings, stop lines, side-street kerbs, car rears, window rows): the lateral "
        "vanishing point's candidates.",
        "geometry: lines across the street 3 m above or below the camera, 5-20 m ahead and up to 10 m to "
        "either side slant by at most 17 deg in a camera turned 30 deg off the street; the margin is for "
        "pitch, roll and wider lenses",
    )
    lateral_direction_std_deg: float = param(
        8.0,
        "deg",
        "Spread of the direction of lines across the street around square to it (crossings and side streets "
        "at an angle, cars turned in their lane); it enters the lateral focal cue's spread.",
        "convention: as shape_yaw_std_deg, the spread of a vehicle's heading around the street's",
    )
    roll_prior_std_deg: float = param(
        3.0,
        "deg",
        "Prior spread of the camera roll around level, a nuisance of the lateral vanishing point's focal cue.",
        "convention: as the pitch prior (a vehicle or hand-held camera held about level)",
    )
    lateral_roll_steps: int = param(
        25, "count", "Rolls searched by the lateral focal cue (evenly over three prior sigmas each side).",
        "convention: resolution only (0.75 deg steps)",
    )
    vertical_bootstrap: int = param(
        40, "count", "Bootstrap resamples of the vanishing points' inliers for the focal length's spread.",
        "convention: resolution only",
    )
    shape_length_rel_std: float = param(
        0.11,
        "fraction",
        "Relative spread of a vehicle's length and width around its class size (the object-shape focal cue).",
        "published: KITTI car length 3.88 +- 0.43 m, width 1.63 +- 0.10 m (Geiger et al. 2012 label statistics)",
    )
    shape_car_size_m: tuple[float, float, float] = param(
        (4.23, 1.78, 1.62),
        "m",
        "Length, width and height of a car in the object-shape focal cue. Only the proportions move the "
        "focal length (a car scaled as a whole fits the same f with another camera height); the class "
        "table's car (4.2 x 1.8 x 1.5 m, its height chosen for the camera-height fit) is flatter than "
        "any published car mean (width/height 1.20 and length/height 2.80 against 1.07-1.13 and "
        "2.54-2.68) and so reads the focal length long.",
        "published: geometric mean of the KITTI Car label mean 3.88 x 1.63 x 1.53 m (g_type_mean_size, "
        "Qi et al. 2018, Frustum PointNets) and the nuScenes car mean 4.61 x 1.95 x 1.72 m "
        "(mmdetection3d's nuScenes anchor sizes)",
    )
    shape_yaw_std_deg: float = param(
        8.0,
        "deg",
        "Spread of a vehicle's heading around the street's direction (lane changes, bends, parking at an angle): "
        "it widens or narrows the side a box shows.",
        "convention: a lane change over 30 m at 50 km/h turns a car by about 6-8 deg",
    )
    shape_cross_fraction: float = param(
        0.1,
        "fraction",
        "Share of vehicles in the object-shape focal cue taken to stand across the street rather than along "
        "it (crossing or turning at a junction, parked across): each vehicle's box is a mixture of the two, so "
        "one wide box across the street does not read as a short focal length.",
        "convention: a robust mixture's outlier share, one vehicle in ten",
    )
    shape_focal_range: tuple[float, float] = param(
        (0.25, 2.0),
        "1",
        "Focal lengths searched by the object-shape cue, as fractions of the image diagonal.",
        "convention: 150 deg diagonal to a short telephoto",
    )
    shape_grid: tuple[int, int, int] = param(
        (56, 37, 49), "count", "Object-shape cue grid: focal lengths (log spaced), camera heights (3 prior sigmas), horizon rows (within 2 pitch-prior sigmas at 1.5x the prior focal length).",
        "convention: resolution only",
    )
    shape_min_objects: int = param(
        2, "count", "Fewest vehicles whose box shape measures the focal length.", "convention: one is not robust"
    )

    # --- the roll from the vertical vanishing point (geometry/roll.py) ---
    roll_level_std_deg: float = param(
        1.0,
        "deg",
        "Prior spread of a vehicle camera's roll about level, fused with the vertical vanishing point's roll.",
        "convention: a camera mounted level on a car; the body rolls under 1 deg in ordinary driving "
        "(lateral acceleration 0.3 g at a roll gradient of about 3 deg/g would roll it more, on bends only)",
    )
    roll_vertical_sigma_deg: float = param(
        0.5,
        "deg",
        "Spread of the roll the vertical vanishing point measures beyond its segments' bootstrap: poles and "
        "building edges that do not stand plumb, lens distortion near the image edge.",
        "convention: street furniture and facades stand plumb to about half a degree",
    )
    roll_road_crossfall_deg: float = param(
        1.15,
        "deg",
        "Spread of the road's tilt across the street against gravity: the vertical vanishing point measures the "
        "roll against gravity, the world's ground is the road (the car sits on it), so this is added to the "
        "measurement's spread.",
        "published: road crossfall 1.5-2.5 % each side of the crown (AASHTO, A Policy on Geometric Design of "
        "Highways and Streets, 2018, sec. 4.2.2); atan(0.02)",
    )
    roll_outlier_sigma: float = param(
        3.0,
        "sigma",
        "A vanishing point's roll further than this from level (their combined sigma) is dropped: the camera "
        "stays level.",
        "convention: three sigmas, as focal_outlier_sigma",
    )
    # --- lane markings and the camera height their spacing measures (geometry/lanes.py) ---
    lane_height_cue: bool = param(
        False,
        "flag",
        "Whether the photo's painted lane lines (their spacing) enter the camera-height fit. Measured on all "
        "real data it did not help: the lane width's spread and lines that are rails or kerbs outweigh what it "
        "adds to the objects' heights, so it is off until lane widths are known per road.",
        "tuned: KITTI 25 frames and nuScenes front, median depth error with / without it: 4.70 / 4.70 % with the "
        "calibration, 7.89 / 7.40 % without a camera file, 5.06 / 4.83 % with road planes, nuScenes 5.97 / 5.97 % "
        "(session 9, lanes.bench.md)",
    )
    lane_width_m: float = param(
        3.25,
        "m",
        "Mean centre-to-centre spacing of neighbouring lane lines (the lane-width height cue).",
        "published: urban lane widths 2.75-3.75 m, 3.25 m the common main-road value (FGSV RASt 06, "
        "Richtlinien fuer die Anlage von Stadtstrassen, lane widths); US 10-12 ft = 3.0-3.6 m "
        "(AASHTO, A Policy on Geometric Design of Highways and Streets, 2018, lane widths)",
    )
    lane_width_std_m: float = param(
        0.3,
        "m",
        "Spread of that spacing: 2.75-3.75 m is its mean +- 1.7 sigma.",
        "published: the ranges of lane_width_m (RASt 06; AASHTO 2018)",
    )
    lane_width_within_std_m: float = param(
        0.15,
        "m",
        "Spread of one lane's width about the width of its road's lanes (edge and turning lanes are narrower, "
        "a marking's own width), on top of each pair's fit; the road's width itself varies by lane_width_std_m.",
        "convention: half the step between RASt 06's lane widths (3.00, 3.25, 3.50 m)",
    )
    lane_agreement_sigma: float = param(
        2.5,
        "sigma",
        "Two neighbouring pairs of lines (three lines) count as lanes only when their spacings agree within this "
        "many combined lane_width_within_std_m spreads; a lone pair is not used.",
        "convention: two and a half sigmas, a 2 % false rejection for two lanes of one road",
    )
    lane_pair_inlier_fraction: float = param(
        0.5,
        "fraction",
        "Prior probability that two neighbouring lines found are one lane apart; the rest (a kerb, a rail, a "
        "parking or bus lane, a line missed between two) are uniform over the spacings the searched heights "
        "allow, a robust mixture.",
        "convention: an even prior, as uncertain as a mixture weight can be",
    )
    lane_marking_width_m: tuple[float, float] = param(
        (0.10, 0.30),
        "m",
        "Narrowest and widest painted line along the street: the top-hat keeps stripes up to "
        "lane_kernel_factor times the widest, and rows where the narrowest is under lane_min_stripe_px "
        "are not searched.",
        "published: German lines 0.12 m (narrow) and 0.25 m (broad) (FGSV RMS-1, Richtlinien fuer die Markierung von Strassen); "
        "US 4-6 in, wide lines 8 in (MUTCD 2009, sec. 3A.06)",
    )
    lane_kernel_factor: float = param(
        2.5,
        "1",
        "Top-hat width as a multiple of the widest marking's width at that row: wider bright things (kerbs, "
        "car bodies, sunlit road) are dropped.",
        "convention: a stripe must fit with road on both sides",
    )
    lane_min_stripe_px: float = param(
        2.0, "px", "Rows where the narrowest marking is thinner than this are not searched.",
        "convention: a stripe must span two pixels to be told from noise",
    )
    lane_min_contrast: float = param(
        30.0,
        "grey level",
        "Least brightness of a stripe above the road round it (white top-hat of the 8-bit grey image).",
        "convention: white or yellow paint on asphalt is 60-150 levels brighter in daylight; 30 keeps worn "
        "lines and drops the road's texture (checked by eye on KITTI frames 4, 7, 9)",
    )
    lane_run_slack: float = param(
        2.0,
        "1",
        "A run of stripe pixels along a row counts as a marking when its width is within this factor of the "
        "narrowest and widest marking's width at that row (the camera-height prior sets the scale).",
        "convention: the camera height prior's 20 % and a pixel of blur either side",
    )
    lane_flank_max_std: float = param(
        12.0,
        "grey level",
        "Largest grey-level spread of the road beside a stripe: paint lies on plain asphalt, rails on gravel, "
        "paving joints and grass blades on textured ground.",
        "convention: asphalt's grain in 8-bit daylight photos is 3-8 levels (checked by eye on KITTI frames 4, 7, 9, 13)",
    )
    lane_box_margin_fraction: float = param(
        0.1, "fraction", "Objects' boxes are widened by this fraction of their width on each side and below "
        "before their pixels are left out of the marking search.", "convention: a wheel or a shadow's edge",
    )
    lane_vote_step_deg: float = param(
        0.5, "deg", "Angle (from the image vertical) bins of the lines' vote.", "convention: resolution only"
    )
    lane_fit_tol_px: float = param(
        3.0, "px", "Stripe pixels further than this from a line's fit are dropped and refitted.",
        "convention: half a narrow marking's width near the camera",
    )
    lane_edge_noise_px: float = param(
        1.0, "px", "Noise of a stripe's centre column per row, added to the fit's scatter.",
        "convention: one pixel of quantisation",
    )
    lane_min_rows: int = param(
        20, "count", "Fewest distinct image rows a lane line must cover.", "convention: a line, not a spot"
    )
    lane_vp_tol_fraction: float = param(
        0.05,
        "fraction",
        "A line's column at the vanishing row must be within this fraction of the image width of the street's "
        "vanishing point (lines along the street pass through it, up to the point's error and a gentle bend).",
        "convention: a few times the vanishing point's scatter on KITTI (30 px of 1242 seen on frame 1)",
    )
    lane_min_extent_fraction: float = param(
        0.15,
        "fraction",
        "A line must span at least this fraction of the rows between the horizon and the image's bottom.",
        "convention: a dashed line shows at least two dashes",
    )

    @property
    def height_prior_m(self) -> tuple[float, float]:
        """(mean, spread) of the camera-height prior, metres."""
        return (self.height_prior_mean_m, self.height_prior_std_m)


#: The defaults (the default argument of the camera stage's public functions).
DEFAULT_CAMERA = CameraParams()
