"""Tuned numbers of the multi-view fusion (:mod:`usdworld.views.fusion`).

A section of its own, not a field of :class:`~usdworld.parameters.Parameters`, so that the
single-image build's ``report.json`` (which records every section) stays as it was; a
multi-view build records these values under ``views -> parameters``.
"""

from __future__ import annotations

from dataclasses import dataclass

from usdworld.parameters.base import param


@dataclass(frozen=True)
class ViewsParams:
    """Thresholds of association and fusion across views; each field documents its unit, meaning and origin."""

    lateral_sigma_rel: float = param(
        0.02,
        "fraction",
        "Standard deviation of a placed object's position across its viewing ray, as a fraction of its "
        "range from the camera: the box centre's column fixes the bearing to a few pixels, and the "
        "footprint centre lies behind the visible face by part of the object's width.",
        "geometry: about 25 px of a 1266 px focal length (nuScenes), half a car's width at 50 m",
    )
    lateral_sigma_min_m: float = param(
        0.25,
        "m",
        "Floor of the across-ray standard deviation: a footprint centre is not better known than a "
        "quarter metre across the ray however near the object is.",
        "geometry: about half a pedestrian's footprint",
    )
    fallback_depth_rel_sigma: float = param(
        0.15,
        "fraction",
        "Along-ray standard deviation, as a fraction of the depth, of an object none of whose depth "
        "cues carries a spread.",
        "convention: above the 6 % median relative depth error measured on nuScenes CAM_FRONT, as a cue-less object is less sure",
    )
    gate_contact_row_error_px: float = param(
        1.0,
        "px",
        "Contact-row error the observations of a multi-view build are given for association, fusion "
        "and the motion test: a contact cue's spread is widened from the single view's quantisation "
        "(PerceptionParams.contact_row_error_px) to this many pixels of row. A view's depth errs by "
        "more than its row: the footprint behind the contact follows the guessed heading, and a "
        "parked car's error drifts as the camera nears it; the gates were set with a whole pixel.",
        "tuned: synthetic drives (seeds 11-13, cached views re-fused): with the quantisation spread in "
        "the gates 31 / 6 / 9 standing cars and people are called moving, with a whole pixel 4 / 1 / 2 "
        "(main: 10 / 2 / 3)",
    )
    cut_sigma_share: float = param(
        0.5,
        "fraction",
        "An object cut by its image's border has a footprint centre known only to within part of its "
        "size: this share of its larger footprint extent is added to both standard deviations.",
        "geometry: the hidden part of a cut box moves its centre by up to half the object's length",
    )
    association_gate_chi2: float = param(
        9.21,
        "1",
        "Two objects of one class seen by different views are one object when the squared Mahalanobis "
        "distance of their ground positions (their covariances summed) is at most this.",
        "published: the chi-square 99 % quantile with 2 degrees of freedom",
    )
    triangulated_ratio: float = param(
        0.5,
        "fraction",
        "A fused object counts as triangulated (its rays cross, rather than its depths averaging) when "
        "the largest variance of the fused position is below this fraction of the variance that "
        "inverse-variance fusion of its depths alone would leave.",
        "convention: the rays halve the along-ray variance",
    )
    frame_gap_s: float = param(
        0.025,
        "s",
        "Views whose timestamps, in order, follow each other within this are one frame of a drive (one "
        "moment of a camera rig); a longer gap starts the next frame.",
        "published: half the 50 ms sweep of nuScenes' 20 Hz LiDAR, which triggers its six cameras one "
        "after another (one sample's images span about 43 ms, 5-20 ms apart)",
    )
    vehicle_speed_max_mps: float = param(
        14.0,
        "m/s",
        "Standard deviation of the prior on a vehicle's ground speed when a drive's frames are tracked: "
        "how far a car, truck, bus, bicycle or motorcycle may have moved between frames before its "
        "own observations say how fast it goes.",
        "published: the 50 km/h (13.9 m/s) urban speed limit of most European countries",
    )
    vehicle_standing_share: float = param(
        0.95,
        "fraction",
        "Prior probability that a tracked vehicle stands (is parked) rather than moves. A drive's vehicle "
        "track is associated as a mixture of a standing hypothesis (velocity 0) and a moving one (the "
        "vehicle_speed_max_mps prior), weighted by this prior times each hypothesis' evidence in the "
        "track's frames: a track of one or two frames is not given the moving hypothesis' wide gate alone.",
        "published: the average car is parked 95 % of the time (Shoup, The High Cost of Free Parking, 2005)",
    )
    person_speed_max_mps: float = param(
        2.6,
        "m/s",
        "Standard deviation of the prior on a person's (or rider's, when no vehicle class applies) "
        "ground speed when a drive's frames are tracked.",
        "published: twice the 1.3 m/s comfortable walking speed of adults (Bohannon 1997)",
    )
    person_walking_speed_mps: float = param(
        1.32,
        "m/s",
        "Mean ground speed of a walking person: the prior on a moving person's speed when its track is "
        "placed (the direction is the fit's own; see person_walking_speed_sd_mps).",
        "published: pedestrians observed crossing streets at signalled crosswalks, 1.32 (SD 0.31) m/s, "
        "N = 139 (Andrews et al. 2010, J. Geriatr. Phys. Ther. 33(3)); laboratory comfortable speeds of "
        "adults aged 20-79 lie at 1.27-1.46 m/s per age and sex group (Bohannon 1997)",
    )
    person_walking_speed_sd_mps: float = param(
        0.31,
        "m/s",
        "Standard deviation of a walking person's ground speed about person_walking_speed_mps.",
        "published: the spread of the street-crossing pedestrians' speeds, 1.32 (SD 0.31) m/s "
        "(Andrews et al. 2010)",
    )
    moving_speed_min_mps: float = param(
        0.5,
        "m/s",
        "A tracked vehicle or person is moving only when its fitted ground speed is at least this "
        "(and the speed is significant at association_gate_chi2): slower drifts are what depth errors "
        "that change with range make of a standing object.",
        "published: under half the slowest comfortable walking speed, 1.27 m/s (Bohannon 1997)",
    )
    moving_min_frames: int = param(
        3,
        "count",
        "Fewest frames a track needs before it can be moving: two fix a constant velocity, a third checks it.",
        "geometry: a constant-velocity fit has no residual with two frames",
    )
    track_gap_s: float = param(
        1.0,
        "s",
        "A track not observed for longer than this is closed; a later observation of its class starts a new one.",
        "convention: ten frames at KITTI's 10 Hz, about as long as a passing car hides what stands behind it",
    )
    frame_error_correlation: float = param(
        0.5,
        "fraction",
        "Share of one frame's placement error variance that the other frames of a drive repeat (a bias "
        "of the object's single-view depth, not noise): a standing track's position is known no better "
        "than this times one frame's error covariance (its surest frame's stated one, or its frames' "
        "measured scatter divided by 1 minus this when larger), however many frames it has; fragments "
        "of one object are merged within association_gate_chi2 of that floored covariance.",
        "tuned: measured on synthetic drives (synth --sequence 100, seeds 11 and 12): the spread across "
        "objects of their mean relative depth error (0.036-0.041) equals the spread within an object "
        "(0.036-0.041), so about half the variance is common to its frames",
    )
    split_depth_sigmas: float = param(
        0.5,
        "1",
        "Within one frame of a drive, two placements of a class that cannot move are one object cut in "
        "two by its single view (a tree's crown split by what stands in front of it) when their "
        "footprints overlap across the viewing ray (their contacts nearer across it than their "
        "footprints reach: the radii of the discs inscribed in them, a street lamp's arm as far as it "
        "lies across the ray) and along it within this many standard deviations of their depth "
        "difference beyond the sum of the discs' radii.",
        "tuned: on the synthetic drives (synth --sequence 100, seeds 11-13; 0, 0.5, 1, 1.5 and 2.58 "
        "compared): larger values place more trees once but at the mean of a precise and a far-off "
        "fragment",
    )
    scatter_min_frames: int = param(
        3,
        "count",
        "Fewest frames of a standing track whose robust scatter (median absolute deviation about the "
        "median, along and across the viewing ray) measures its per-frame error when fragments are "
        "joined; a shorter track uses its surest frame's stated covariance and, for a trunk class "
        "(tree, pole, sign), joins the longer standing track whose footprint all its rays pass through "
        "(its depth failed, its bearing did not).",
        "geometry: a median of three values is the fewest that one failed frame cannot set",
    )
    bearing_sigma_rad: float = param(
        0.002,
        "rad",
        "Standard deviation of the bearing from a drive's camera to the ground contact of a standing "
        "trunk object (tree, pole, sign): the column of its trunk's base, which a moving camera sees "
        "from other directions in each frame; the across-ray spread is this times the range.",
        "tuned: on the synthetic drives (synth --sequence 100, seeds 11-13; 0.001, 0.002 and 0.004 compared): "
        "the frames' median across-ray error of trunk objects is 0.02-0.07 m at 20-45 m, about half a "
        "pixel of a 512 px image",
    )
    bearing_sigma_min_m: float = param(
        0.02,
        "m",
        "Floor of a trunk contact's across-ray standard deviation in a drive's bearing triangulation.",
        "geometry: about a tenth of a thin trunk's or post's width",
    )
    bearing_outlier_scale: float = param(
        1.0,
        "1",
        "Scale, in bearing standard deviations, of the Cauchy weight 1 / (1 + (r / scale)^2) that a "
        "frame's across-ray residual r gets in a drive's bearing triangulation: a frame whose contact "
        "is another point (a crown cut by what stands in front, a neighbour) counts for little.",
        "tuned: on the synthetic drives (synth --sequence 100, seeds 11-13; 0.5, 1 and 2, Huber and Cauchy "
        "weights compared; an information discount for bearing errors shared by the frames, 0.2 and 0.5, "
        "placed fewer objects once)",
    )
