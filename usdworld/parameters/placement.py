"""Tuned numbers of the placement stage (see :mod:`usdworld.parameters.base` for the field conventions).

Origins name the commit subject or benchmark that chose a value where one did; "tuned:
synthetic set" values were measured with ``tools/eval_synth.py`` (BENCHMARKS.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from usdworld.parameters.base import param

if TYPE_CHECKING:
    import numpy as np

_SYNTH = "tuned: synthetic set"
_PAPER = (
    "published: the paper usdworld implements (Building 3D Virtual Worlds From Monocular Images of "
    "Urban Road Traffic Scenes), step 1 post-processing"
)


@dataclass(frozen=True)
class PlacementParams:
    """Thresholds of the placement stage; each field documents its unit, meaning and origin."""

    # --- ground and drafting -------------------------------------------------------------
    curb_height_m: float = param(
        0.15,
        "m",
        "Height of the kerb: objects standing on the sidewalk are lifted by this much, and a "
        "contact seen on the sidewalk is that much above the road plane the homography maps to.",
        "published: typical kerb height of urban streets, 0.1-0.2 m (e.g. FHWA, Manual on "
        "Uniform Traffic Control Devices; German RASt 06 gives 0.12-0.15 m)",
    )
    guess_depth_m: float = param(
        10.0,
        "m",
        "Where along its contact pixel's ray an object whose contact is not on the ground is put to "
        "guess its yaw for the silhouette-height cue (the yaw only turns the top's offsets).",
        "convention: a typical street-scene depth; the guess has no measured effect",
    )
    wall_trace_step_px: float = param(
        20.0,
        "px",
        "Rows between the two pixels of an image column whose ground points give the line that "
        "column sees on the ground (where it meets a facade's foot); any step below the horizon works.",
        "geometry: two points of the column's vertical plane on the ground",
    )
    top_shape_offset: float = param(
        0.1,
        "1",
        "Added to top-shape ratios (perception.shape.top_shape_ratio) before comparing a mask's "
        "with a variant's in log space, so that near-zero ratios (round tops) compare on a sane scale.",
        f"{_SYNTH} (c607624: variants by the shape of the top)",
    )
    behind_gap_m: float = param(
        0.3,
        "m",
        "Gap left between an object placed behind its occluder and that occluder's back.",
        f"{_SYNTH} (87db2ec: occluder lower bound)",
    )
    # --- confidence of a placement by what decided its depth --------------------------------
    confidence_contact: float = param(
        0.9, "1", "Confidence of a depth decided by the seen ground contact.", _SYNTH
    )
    confidence_fused: float = param(0.8, "1", "Confidence of a depth fused from several cues.", _SYNTH)
    confidence_cnn: float = param(0.7, "1", "Confidence of a depth decided by the dense depth map.", _SYNTH)
    confidence_height: float = param(
        0.6, "1", "Confidence of a depth decided by the class-height prior.", _SYNTH
    )
    confidence_contact_partial: float = param(
        0.3, "1", "Confidence of a depth bounded by a hidden or cut bottom's visible ground point.", _SYNTH
    )
    confidence_street_line: float = param(
        0.5, "1", "Confidence of a depth given by the class's street row.", _SYNTH
    )
    confidence_top_row: float = param(
        0.3, "1", "Confidence of a depth from the top row and class height.", _SYNTH
    )
    confidence_behind: float = param(0.25, "1", "Confidence of a depth just behind the occluder.", _SYNTH)
    confidence_height_partial: float = param(
        0.2, "1", "Confidence of a depth bounded by a cut object's visible height.", _SYNTH
    )
    # --- street rows ---------------------------------------------------------------------
    row_min_support: int = param(
        1,
        "count",
        "Objects with a seen contact needed on a side of the street to measure their class's row "
        "(one tree with its trunk in view sets the row for the others behind parked cars).",
        f"{_SYNTH} (0f9489c: street rows)",
    )
    row_max_spread_m: float = param(
        0.75,
        "m",
        "A row of trees, poles or signs whose members' offsets spread more than this (median "
        "absolute deviation) is no row: the class stands anywhere on that side.",
        f"{_SYNTH} (0f9489c: street rows)",
    )
    facade_row_max_spread_m: float = param(
        1.5,
        "m",
        "The same spread limit for a row of facades (a building line is rougher than a kerb line).",
        f"{_SYNTH} (0f9489c: street rows)",
    )
    line_bound_slack: float = param(
        0.1,
        "fraction",
        "A row's depth may exceed an object's own upper bound (its visible bottom's ground point) by "
        "this fraction plus line_bound_slack_m before the two are taken to disagree.",
        f"{_SYNTH} (0f9489c: street rows)",
    )
    line_bound_slack_m: float = param(
        1.0,
        "m",
        "Absolute part of the row/upper-bound slack; a row may also fall this much short of the "
        "occluder's front before they disagree.",
        f"{_SYNTH} (0f9489c: street rows)",
    )
    row_sigma_floor_m: float = param(
        0.25,
        "m",
        "Smallest spread across the street given to a row's depth cue (one member measures no spread).",
        f"{_SYNTH} (0f9489c: street rows)",
    )
    row_lateral_floor_m: float = param(
        1.0,
        "m",
        "Added to a row's distance from the road axis when its spread is magnified by the ray's "
        "angle to the row (keeps a row on the axis from dividing by zero).",
        f"{_SYNTH} (0f9489c: street rows)",
    )
    tree_kerb_setback_m: float = param(
        1.0,
        "m",
        "Where street trees (crown classes) stand behind the kerb when none of their row is seen.",
        "published: customary planting distance of street trees from the kerb, about 1 m "
        "(c3c1484: rows from the sidewalk)",
    )
    post_kerb_setback_m: float = param(
        0.5,
        "m",
        "Where posts and signs (the other non-facade row classes) stand behind the kerb when none "
        "of their row is seen.",
        "published: customary lateral clearance of street furniture from the kerb, about 0.5 m "
        "(c3c1484: rows from the sidewalk)",
    )
    sidewalk_edge_percentiles: tuple[float, float] = param(
        (5.0, 95.0),
        "percent",
        "The sidewalk's kerb and back edge: these percentiles of its points' distances from the "
        "road axis (a few stray label pixels do not move them).",
        f"{_SYNTH} (c3c1484: rows from the sidewalk)",
    )
    min_sidewalk_points: int = param(
        50,
        "count",
        "A side's sidewalk gives rows only when measured from at least this many ground points.",
        f"{_SYNTH} (c3c1484: rows from the sidewalk)",
    )
    sidewalk_row_spread_fraction: float = param(
        0.25,
        "fraction",
        "A row the sidewalk gives spreads by this fraction of the sidewalk's width.",
        f"{_SYNTH} (c3c1484: rows from the sidewalk)",
    )
    lone_row_tolerance_m: float = param(
        1.5,
        "m",
        "A row measured by one tree, post or sign alone is dropped when it stands further than "
        "this from the row the sidewalk gives its class (that one foot may be ground seen past a crown).",
        f"{_SYNTH} (0b868a6: trees 269 -> 271 at 1024x512)",
    )
    parked_kerb_gap_m: float = param(
        0.3,
        "m",
        "A parked car's kerb side is about this far from the kerb.",
        f"{_SYNTH} (144f1fa: kerb from parked cars)",
    )
    parked_heading_tol_deg: float = param(
        10.0,
        "deg",
        "A car parks along the kerb when its heading is within this angle of the road's, either way.",
        f"{_SYNTH} (144f1fa: kerb from parked cars)",
    )
    parked_min_sideways_m: float = param(
        3.0,
        "m",
        "... and when it stands at least this far to the camera's side, out of the camera's lane.",
        f"{_SYNTH} (144f1fa: kerb from parked cars)",
    )
    parked_row_spread_m: float = param(
        0.5,
        "m",
        "Spread given to a row the parked cars' kerb gives.",
        f"{_SYNTH} (144f1fa: kerb from parked cars)",
    )
    # --- collision order -----------------------------------------------------------------
    stuff_priority_offset: float = param(
        1e6,
        "1",
        "Added to a stuff object's collision priority (depth / confidence, metres) so that every "
        "thing settles before any stuff.",
        "convention: larger than any thing's priority",
    )
    priority_confidence_floor: float = param(
        1e-3,
        "1",
        "Confidence below which a collision priority no longer grows (no division by zero).",
        "convention: numerical floor",
    )
    # --- silhouette and top-row depth ------------------------------------------------------
    silhouette_depth_range_m: tuple[float, float] = param(
        (0.3, 1000.0),
        "m",
        "Depths searched for the silhouette-height and top-row cues (log-spaced grid).",
        "convention: beyond any street scene on both ends",
    )
    silhouette_grid_points: int = param(
        400,
        "count",
        "Grid points of that search (refined by interpolation).",
        "convention: sub-percent steps",
    )
    near_plane_m: float = param(
        0.05,
        "m",
        "Points closer than this along the optical axis are taken as behind the camera when "
        "predicting silhouette rows.",
        "convention: numerical near plane",
    )
    top_row_min_clearance_sigmas: float = param(
        2.0,
        "1",
        "The top-row cue needs the class height to stand this many height spreads clear of the "
        "camera's height (otherwise its sigma exceeds half the depth).",
        f"{_SYNTH} (c607624: top-row depth for hidden bottoms)",
    )
    # --- boxes and road axis -------------------------------------------------------------
    box_align_max_shift: float = param(
        1.0,
        "fraction",
        "Largest sideways correction of the box-column alignment, as a fraction of the object's width.",
        f"{_SYNTH} (87db2ec: box alignment)",
    )
    box_align_iterations: int = param(
        4, "count", "Fixed-point steps of the box-column alignment.", f"{_SYNTH} (87db2ec: box alignment)"
    )
    border_cut_bisections: int = param(
        15,
        "count",
        "Halvings of each bisection placing an object cut by the left or right image border from its seen edge and contact row.",
        "convention: halves the widest search span (about 16 m: a car's diagonal and the seen row's stretch) to half a millimetre",
    )
    border_cut_scan_steps: int = param(
        16,
        "count",
        "Steps of the scan along the viewing ray for the bracket of a border-cut object's contact row (then bisected).",
        "convention: a footprint's diagonal in steps of about 30 cm, finer than a car's length",
    )
    view_angle_step_deg: float = param(
        1.0,
        "deg",
        "Step of the turns from end on (0) to side on (90) tried when fitting a box's aspect.",
        "convention: finer than a box's aspect resolves",
    )
    max_road_axis_angle_deg: float = param(
        45.0,
        "deg",
        "A street seen from a car runs away from the camera: an axis further than this from the "
        "camera's heading is a crossing (or a wrong estimate), not the street.",
        "geometry: half of a right angle separates along from across",
    )
    road_axis_min_points: int = param(
        50,
        "count",
        "Road ground points needed to fit the road axis; fewer fall back to the camera's heading.",
        f"{_SYNTH} (c607624)",
    )
    # --- ordering rules ------------------------------------------------------------------
    ordering_delta_m: float = param(
        1.0, "m", "The paper's threshold delta of its ordering rules 1 and 2.", _PAPER
    )
    ordering_similar_rows_px: float = param(
        2.0,
        "px",
        'Contact rows closer than this count as the paper\'s "similar Y" in its ordering rules.',
        "convention: the paper gives no number; two pixels of label noise",
    )
    # --- headings ----------------------------------------------------------------------
    lane_width_m: float = param(
        3.5,
        "m",
        "Width of one traffic lane: the line dividing the two directions of traffic lies at least "
        "half of it to the camera's oncoming side, and a heading's confidence grows to 1 one lane "
        "away from that line (layout.heading).",
        "published: RAA 2008 (German motorway design guideline) and the AASHTO Green Book "
        "(2018): standard lanes 3.5 m and 3.6 m",
    )

    ground_height_sigma_m: float = param(
        0.0,
        "m",
        "Spread of the road surface's height under an object about the camera's ground plane. The "
        "plane is the road under the camera (a given plane is fitted round the car; an estimated one "
        "to all contacts); an object one or two lanes over stands on a road that falls away across "
        "its crossfall. A ground contact's depth scales with the camera's height above the object's "
        "own ground, so this widens the contact cue by depth * sigma / camera height, given camera or not. "
        "Off (0) by default: 0.14 m (2 % crossfall across two 3.5 m lanes) makes KITTI 0-9 with their road "
        "planes 6.7 % -> 4.1 % and nuScenes 6.1 % -> 5.5 %, but the synthetic set (flat ground) 0.43 -> 1.08 m "
        "for cars (measured with the road plane fixed). With the plane a prior that the objects refine "
        "(CameraParams.plane_height_sigma_m) 0.14 m moves KITTI 0-9 --planes 3.8 % -> 3.4 % but its p90 "
        "7.8 % -> 8.6 % (5 objects better, 6 worse); see BENCHMARKS / the bias report before turning it on. "
        "A camera rig (build --views) measures the spread from its own objects and adds it in quadrature "
        "(usdworld.views.unevenness).",
        "published: road crossfall 1.5-2.5 % (AASHTO, A Policy on Geometric Design of Highways and "
        "Streets, 2018, sec. 4.2.2); default off to keep the synthetic set",
    )

    @property
    def row_outlier_m(self) -> float:
        """A tree or pole whose seen contact lies further than this (metres) beyond its class's
        row on that side is taken to stand in the row: twice the spread a row's members may have
        (8ae85a4: 2.5 m -> 1.5 m, trees 273 -> 275 of 283 at 2048x1024)."""
        return 2.0 * self.row_max_spread_m

    @property
    def parked_heading_tol(self) -> float:
        """:attr:`parked_heading_tol_deg` in radians."""
        return math.radians(self.parked_heading_tol_deg)

    @property
    def max_road_axis_angle(self) -> float:
        """:attr:`max_road_axis_angle_deg` in radians."""
        return math.radians(self.max_road_axis_angle_deg)

    @property
    def view_angles_deg(self) -> np.ndarray:
        """(K,) float64 turns tried when fitting a box's aspect, 0 to 90 degrees inclusive."""
        import numpy as np  # the parameters package is a leaf that CLI start-up imports: numpy only when used

        return np.arange(0.0, 90.0 + 0.5 * self.view_angle_step_deg, self.view_angle_step_deg)
