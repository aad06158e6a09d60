"""Tuned numbers of the perception stage (see :mod:`usdworld.parameters.base` for the field conventions).

Per-class numbers (:attr:`PerceptionParams.split_aspect`, :attr:`PerceptionParams.min_thin_area_fraction`)
are tuples of ``(class name, value)`` pairs here rather than fields of the class table: they are
thresholds tuned on data like every other field of this section (the class table holds what a class
*is* and measures), and keeping them here puts them in ``report.json`` with the rest of the tuning.
"""

from __future__ import annotations

from dataclasses import dataclass

from usdworld.parameters.base import param

_SYNTH = "tuned: synthetic set"


@dataclass(frozen=True)
class PerceptionParams:
    """Thresholds of the perception stage; each field documents its unit, meaning and origin."""

    # --- objects from masks and boxes (perception/objects.py) ---
    split_aspect: tuple[tuple[str, float], ...] = param(
        (("building", 1.0), ("fence", 2.5)),
        "1",
        "Stuff classes split into chunks of about this width/height aspect, by class; classes not "
        "listed are never split (crowns are cut by their tops, facades by perspective when it is known).",
        f"{_SYNTH} (core pipeline, commit 07357ff)",
    )
    min_stuff_area_fraction: float = param(
        4e-4,
        "fraction",
        "Smallest stuff region kept, as a fraction of the image area (never below min_stuff_area_px).",
        f"{_SYNTH} (core pipeline, commit 07357ff)",
    )
    min_stuff_area_px: int = param(
        30, "px", "Floor of the smallest stuff region (and of a facade piece), pixels.", f"{_SYNTH} (commit 07357ff)"
    )
    min_thin_area_fraction: tuple[tuple[str, float], ...] = param(
        (("pole", 5e-5), ("traffic_sign", 1e-4), ("traffic_light", 1e-4)),
        "fraction",
        "min_stuff_area_fraction for thin street furniture, by class (a pole 40 m away is a few pixels "
        "wide; poles lowest, as their pieces are joined through what stands in front).",
        f"{_SYNTH}: thin street furniture kept down to 0.01 % of the image (commit 44ebbee)",
    )
    facade_piece_area: float = param(
        0.25,
        "fraction",
        "A facade region is cut into pieces of at least this fraction of the smallest stuff area each "
        "(far down the street a building is a few columns wide).",
        f"{_SYNTH} (commit 12d4ae2)",
    )
    min_thing_area_px: int = param(10, "px", "Smallest thing instance kept, pixels.", f"{_SYNTH} (commit 07357ff)")
    occluded_fraction: float = param(
        0.5,
        "fraction",
        "A detection box's bottom counts as occluded when a lower box covers this fraction of its bottom edge.",
        "convention: a majority of the edge (commit 07357ff)",
    )
    hidden_side_fraction: float = param(
        0.5,
        "fraction",
        "A mask's left or right side counts as hidden when an object whose bottom is lower in the image "
        "borders it in this fraction of its rows (perception/objects.py hidden_sides).",
        "convention: a majority of the rows, as occluded_fraction",
    )
    same_thing_iou: float = param(
        0.5,
        "fraction",
        "A thing of the segmentation and a detection box are the same object when their boxes overlap by at "
        "least this intersection over union (what hides a stuff region's bottom is then that detection).",
        "published: the PASCAL VOC match criterion (Everingham et al., IJCV 2010, section 4.2)",
    )
    bottom_band_fraction: float = param(
        0.15,
        "fraction",
        "A thing's lowest columns are those whose bottom lies within this fraction of its height of "
        "its lowest pixel (tyres, feet, a trunk).",
        f"{_SYNTH} (commit 87db2ec)",
    )
    bottom_band_min_px: float = param(
        2.0, "px", "The lowest columns' band is at least this many pixels tall.", f"{_SYNTH} (commit 87db2ec)"
    )
    contact_fraction: float = param(
        0.3,
        "fraction",
        "Fraction of a thing's lowest columns that must stand on ground for its contact to count.",
        f"{_SYNTH} (commit 87db2ec)",
    )
    split_min_width_px: int = param(
        4, "px", "A stuff chunk cut by aspect is at least this many columns wide.", f"{_SYNTH} (commit 07357ff)"
    )
    # --- crowns (perception/crowns.py) ---
    crown_prominence_fraction: float = param(
        0.07,
        "fraction",
        "A crown top must rise above its neighbouring dips by this fraction of the tree's height in its column.",
        f"{_SYNTH}: merged crowns cut at the dips between their tops (commit 0f9489c)",
    )
    crown_prominence_px: float = param(
        4.0,
        "px",
        "... and by at least this many pixels (crown tops and feet alike).",
        f"{_SYNTH} (commit 0f9489c)",
    )
    crown_foot_fraction: float = param(
        0.04,
        "fraction",
        "A foot (trunk) must reach below its neighbourhood by this fraction of its column's height "
        "(small: a trunk beside a nearer crown hanging almost to the ground shows only a few pixels).",
        f"{_SYNTH}: trees 190 -> 209 of 283 in the synthetic round trip (commit d156229)",
    )
    # --- facades (perception/facades.py) ---
    frontage_m: float = param(
        12.0,
        "m",
        "A facade whose roofline is out of view is cut into pieces of about this much frontage (a town house).",
        f"{_SYNTH} (commit 44ebbee)",
    )
    roofline_frontage_m: float = param(
        16.0,
        "m",
        "A run of one roofline (its top in view) is cut into pieces of about this frontage: where "
        "buildings' heights differ the roofline has cut them already.",
        f"{_SYNTH} (commit 12d4ae2)",
    )
    roof_step_fraction: float = param(
        0.12,
        "fraction",
        "The roofline steps between neighbouring columns by more than this fraction of the lower "
        "column's height (and at least roof_step_min_px): a new building.",
        f"{_SYNTH} (commit 44ebbee)",
    )
    roof_step_min_px: int = param(
        3, "px", "Smallest roofline step that starts a new building, pixels.", f"{_SYNTH} (commit 44ebbee)"
    )
    min_piece_m: float = param(
        3.0,
        "m",
        "A roofline piece with less frontage than this joins its left neighbour; no piece cut from a "
        "building's seen end is shorter.",
        f"{_SYNTH} (commit 44ebbee)",
    )
    min_below_horizon_px: float = param(
        1.0,
        "px",
        "Base points closer to the horizon than this are too far to measure.",
        "geometry: within a pixel of the horizon the ground distance f*h/(v - v_h) is unbounded",
    )
    # --- depth cues (perception/depth/fusion.py) ---
    contact_row_error_px: float = param(
        1.0 / 12.0**0.5,
        "px",
        "Standard deviation of the ground-contact row (e_v): a mask's lowest row r holds the contact "
        "edge somewhere in [r, r + 1), read as r + 0.5, so the edge is off by a uniform error of one "
        "pixel's width. It weighs the contact cue against the height cue; the multi-view association "
        "and motion tests widen it again (ViewsParams.gate_contact_row_error_px).",
        "geometry: the standard deviation of a uniform error over one pixel, 1/sqrt(12) px "
        "(measured on synthetic drives, exact masks: 0.34-0.40 px at 30-200 m)",
    )
    contact_rel_sigma: float = param(
        0.01,
        "fraction",
        "Relative floor of the contact cue's sigma (r_c), for road camber and pitch error.",
        "convention: an allowance for road camber and pitch error, not measured (commit 2eabc1f)",
    )
    cnn_rel_sigma: float = param(
        0.10,
        "fraction",
        "Relative sigma of the depth-map cue (r_n).",
        "published: typical AbsRel of aligned monocular depth networks on KITTI, about 0.1 "
        "(Godard et al. 2019, 'Digging Into Self-Supervised Monocular Depth Estimation', Table 1)",
    )
    height_rel_std: float = param(
        0.10,
        "fraction",
        "Spread of a class's heights, as a fraction of the height, when none is given.",
        "convention: fallback where the class table gives no spread (commit 2eabc1f)",
    )
    height_mean_rel_sigma: float = param(
        0.10,
        "fraction",
        "Uncertainty of a class's mean height itself (fleets and populations differ), added to the "
        "height cue when the camera height was given.",
        "convention: an allowance for differing fleets and populations, not measured (commit 60b8416)",
    )
    erosion_px: int = param(
        2,
        "px",
        "Erosion of an object's mask before averaging the depth map (mask edges mix foreground and background).",
        "convention: network depth edges blur over a pixel or two (commit 2eabc1f)",
    )
    min_cnn_pixels: int = param(
        10, "count", "Fewest depth pixels for the depth-map cue.", "convention: chosen with the code (commit 2eabc1f)"
    )
    dominant_share: float = param(
        0.8,
        "fraction",
        "A cue holding at least this share of the fused weight names the depth method.",
        "convention: provenance wording only, no effect on positions",
    )
    # --- alignment of network depth to the ground (perception/depth/align.py, ground.py) ---
    align_max_ground_depth_m: float = param(
        80.0,
        "m",
        "Ground pixels farther than this are not used to align a depth map: their depth is too "
        "sensitive to pitch and to the road not being flat.",
        "convention: the range placement works within (commit 2eabc1f)",
    )
    align_max_depth_m: float = param(
        1000.0,
        "m",
        "Aligned depths beyond this are marked invalid (inverse-depth fits explode near 0).",
        "convention: far beyond any placed object",
    )
    align_min_ground_pixels: int = param(
        50, "count", "Fewest usable ground pixels for an alignment fit.", "convention: chosen with the code (commit 2eabc1f)"
    )
    align_min_inlier_ratio: float = param(
        0.3,
        "fraction",
        "Fewest inliers, as a fraction of the ground pixels, for an alignment fit to be accepted.",
        "convention: chosen with the code (commit 2eabc1f)",
    )
    # --- colours from the photo (perception/appearance.py) ---
    colour_inner_margin: float = param(
        0.15,
        "fraction",
        "An object's colour is sampled inside its box shrunk by this fraction of its width and height on "
        "each side (box edges hold background; the middle holds paint, facade, foliage).",
        "convention: chosen with the code (issue 18)",
    )
    colour_body_rows: tuple[tuple[str, tuple[float, float]], ...] = param(
        (("car", (0.45, 0.9)), ("van", (0.45, 0.9))),
        "fraction",
        "Band of the box height (top, bottom, from the top) whose pixels give a class's body colour: "
        "a car's and a van's doors and bumpers, below the windows (which fill most of a near car's box "
        "seen from the side) and above the tyres; classes not listed use the whole box.",
        "tuned: KITTI training 000010-000024 built from their boxes, median per-object CIE76 7.8 "
        "(8.1 without the band; 000000-000009 held out: 8.7, 7.6 without: the measure is flat), kept "
        "because a near car's box is mostly windows (KITTI 000008's red car measured as its windows "
        "without it) (issue 18)",
    )
    colour_trim_dark: float = param(
        0.3,
        "fraction",
        "Darkest fraction of a region's pixels (by luminance) left out of its colour: cast shadows, "
        "tyres, grilles, window interiors (dark pixels are compact in CIELAB and would otherwise "
        "make the densest cluster of a silver or orange car).",
        "tuned: KITTI training 000010-000024 built from their boxes, mean per-object CIE76 10.7 "
        "(0.1: 11.5, 0.2: 10.9, 0.4: 11.4); frames 000000-000009 held out (issue 18)",
    )
    colour_trim_bright: float = param(
        0.03,
        "fraction",
        "Brightest fraction of a region's pixels (by luminance) left out of its colour: specular highlights.",
        "convention: chosen with the code (issue 18)",
    )
    colour_bin_lab: float = param(
        8.0,
        "1",
        "Side of the CIELAB histogram bins whose densest 3x3x3 neighbourhood is the region's dominant colour.",
        "convention: chosen with the code (issue 18)",
    )
    colour_radius_lab: float = param(
        15.0,
        "1",
        "Pixels within this CIE76 distance of the dominant colour make up the trimmed median (a clearly "
        "different colour, such as windows or an occluder, lies farther).",
        "convention: chosen with the code (issue 18)",
    )
    colour_min_pixels: int = param(
        20, "count", "Fewest pixels an object's colour is measured from; fewer keep the asset's colour.",
        "convention: chosen with the code (issue 18)",
    )
    colour_max_samples: int = param(
        5000,
        "count",
        "Most pixels a region's colour is measured from (a regular subsample of larger regions; the "
        "median of 5000 samples is within about 1 % of the whole region's).",
        "convention: chosen with the code (issue 18)",
    )
    # --- streets inferred from the photo without labels (perception/streets.py) ---
    streets_seed_band: float = param(
        0.15,
        "fraction",
        "The road's colour is taken from the band under a vehicle's box this fraction of the box's height deep "
        "(at least 2 px): the road it stands on.",
        "convention: chosen with the code, checked on Cityscapes frankfurt_000000_000294 (labels) and KITTI 000001/000003/000008 (by eye) (issue 18)",
    )
    streets_seed_inset: float = param(
        0.25,
        "fraction",
        "The seed band leaves out this fraction of the box's width at each side (a box seen at an angle "
        "covers the sidewalk at its ends).",
        "convention: the middle half of the box (issue 18)",
    )
    streets_min_seed_px: int = param(
        20, "px", "Fewest seed pixels the road's colour is taken from; fewer fall back to the bottom centre.",
        "convention: a median of 20 samples (issue 18)",
    )
    streets_camera_seed_rows: float = param(
        0.1,
        "fraction",
        "Without vehicles, the road's colour is taken from the lowest rows of the middle third of the image, "
        "this fraction of its height (the ground just ahead of the camera, which stands on the road).",
        "geometry: a 1.5 m camera with a 45 deg vertical field of view sees the ground 3.6 m to 5 m ahead there",
    )
    streets_horizon_margin: float = param(
        0.01, "fraction", "Ground is taken from this fraction of the image height below the horizon on.",
        "convention: a few pixels for the horizon's uncertainty (issue 18)",
    )
    streets_lightness_weight: float = param(
        2.0,
        "1",
        "The CIELAB lightness difference is divided by this before it is added to the chroma difference "
        "(shadows change lightness, not hue).",
        "published: CMC l:c colour difference, l = 2 for acceptability (Clarke, McDonald and Rigg 1984)",
    )
    streets_colour_tolerance: float = param(
        12.0,
        "1",
        "A ground pixel is road-like when its colour difference from the seeds' median (lightness weighted "
        "as above) is below this, in CIELAB units.",
        "convention: chosen with the code, checked on Cityscapes frankfurt_000000_000294 (labels) and KITTI 000001/000003/000008 (by eye) (issue 18)",
    )
    streets_texture_window: float = param(
        0.012,
        "fraction",
        "Side of the window texture (the local spread of lightness) is measured over, as a fraction of the "
        "image width (at least 3 px).",
        "convention: about 3 px at 256 px, 15 px at 1242 px (issue 18)",
    )
    streets_texture_max: float = param(
        6.0, "1", "Floor of the road's texture limit: local lightness spread, CIELAB L* units.",
        "convention: chosen with the code, checked on Cityscapes frankfurt_000000_000294 (labels) and KITTI 000001/000003/000008 (by eye) (issue 18)",
    )
    streets_texture_factor: float = param(
        3.0, "1", "The road's texture limit is at least this multiple of the seeds' median texture.",
        "convention: chosen with the code, checked on Cityscapes frankfurt_000000_000294 (labels) and KITTI 000001/000003/000008 (by eye) (issue 18)",
    )
    streets_edge_min_length: float = param(
        0.05,
        "fraction",
        "Edges at least this fraction of the image width long bound the road and the sidewalk.",
        "convention: chosen with the code, checked on Cityscapes frankfurt_000000_000294 (labels) and KITTI 000001/000003/000008 (by eye) (issue 18)",
    )
    streets_edge_angle_tol: float = param(
        0.0873,
        "rad",
        "An edge bounds the road when it points at the street's vanishing point within this angle (5 deg); "
        "without a vanishing point, when it is steeper than this.",
        "convention: the tolerance of the vanishing-point inliers (issue 18)",
    )
    streets_close_window: float = param(
        0.02,
        "fraction",
        "The road is closed (lane markings, small gaps) with a square of this fraction of the image width.",
        "convention: chosen with the code, checked on Cityscapes frankfurt_000000_000294 (labels) and KITTI 000001/000003/000008 (by eye) (issue 18)",
    )
    streets_min_road_fraction: float = param(
        0.01, "fraction", "Less inferred road than this fraction of the image is refused (nothing inferred).",
        "convention: 1 % of the image (issue 18)",
    )
    streets_sidewalk_width_m: float = param(
        2.5,
        "m",
        "Width of the sidewalk band beside the road, on the ground.",
        "published: RASt 06 (FGSV 2006), the standard side-space width of an urban street, 2.50 m",
    )
    streets_sky_lightness: float = param(
        70.0, "1", "Sky pixels are brighter than this CIELAB L*.", "convention: chosen with the code, checked on Cityscapes frankfurt_000000_000294 (labels) and KITTI 000001/000003/000008 (by eye) (issue 18)",
    )
    streets_sky_texture: float = param(
        4.0, "1", "Sky pixels have a local lightness spread below this, CIELAB L* units.", "convention: chosen with the code, checked on Cityscapes frankfurt_000000_000294 (labels) and KITTI 000001/000003/000008 (by eye) (issue 18)",
    )
    streets_excess_green: float = param(
        0.1,
        "1",
        "Vegetation scores more than this on the excess-green-minus-excess-red index (Meyer and Neto 2008) "
        "of the photo white-balanced on the road, measured from grey (0) and averaged over three texture "
        "windows (dark leaves have noisy chromaticity).",
        "tuned: the best of 0.04 / 0.07 / 0.10 / 0.13 / 0.16 by the inferred map's vegetation IoU on Cityscapes "
        "frankfurt_000000_000294 (the one real frame with vegetation labels: 0.17 / 0.27 / 0.45 / 0.41 / 0.34), "
        "checked by eye on KITTI 000001 and 000008 (issue 18)",
    )
    streets_vegetation_texture: float = param(
        3.0, "1", "Vegetation has a local lightness spread above this (leaves), CIELAB L* units.", "convention: chosen with the code, checked on Cityscapes frankfurt_000000_000294 (labels) and KITTI 000001/000003/000008 (by eye) (issue 18)",
    )

    @property
    def split_aspect_by_class(self) -> dict[str, float]:
        """:attr:`split_aspect` as a mapping."""
        return dict(self.split_aspect)

    def colour_rows(self, class_name: str) -> tuple[float, float]:
        """:attr:`colour_body_rows` of a class, (0, 1) when it is not listed."""
        return dict(self.colour_body_rows).get(class_name, (0.0, 1.0))

    def min_area_fraction(self, class_name: str) -> float:
        """Smallest region of ``class_name`` kept, as a fraction of the image area."""
        return dict(self.min_thin_area_fraction).get(class_name, self.min_stuff_area_fraction)


#: The defaults (the default argument of perception's public functions).
DEFAULT_PERCEPTION = PerceptionParams()
