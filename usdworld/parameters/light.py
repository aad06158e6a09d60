"""Tuned numbers of the light estimate (see :mod:`usdworld.parameters.base` for the field conventions).

The light stage finds the shadows the placed objects cast on the ground next to their
footprints and fits the sun's azimuth and elevation to them; the contrast between the
ground in those shadows and the lit ground decides sunny or overcast
(:mod:`usdworld.perception.light`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from usdworld.parameters.base import param


@dataclass(frozen=True)
class LightParams:
    """Thresholds of the light estimate; each field documents its unit, meaning and origin."""

    sunny_min_contrast: float = param(
        math.sqrt(3.0),
        "ratio",
        "A ground pixel next to a caster counts as shadowed when the lit ground of its surface "
        "is brighter (linear luminance) by at least this factor.",
        "published: daylight illuminance tables (direct sunlight 32,000-100,000 lx, daylight "
        "without direct sun 10,000-25,000 lx: a lit surface is typically 3 to 10 times one in "
        "shadow); sqrt(3) is halfway, in log, between no contrast and the least sunny one",
    )
    lit_percentile: float = param(
        75.0,
        "percent",
        "The lit ground's luminance is this percentile of a ground surface's pixels (road, "
        "sidewalk, terrain each on their own).",
        "convention: most of a street's ground is lit on a sunny day; the few per cent of lane "
        "markings lie above it",
    )
    elevation_range_deg: tuple[float, float] = param(
        (10.0, 80.0),
        "deg",
        "Sun elevations searched.",
        "geometry: below 10 degrees shadows run out of any street view; above 80 degrees an "
        "object's shadow lies under its own footprint",
    )
    coarse_step_deg: float = param(
        9.0,
        "deg",
        "Grid step of the first search over azimuth and elevation; the best cell is then "
        "searched at a third of it and at one degree.",
        "convention: a car's shadow turns by a fraction of its width over 9 degrees",
    )
    reach_max_m: float = param(
        15.0,
        "m",
        "Farthest a caster's shadow is looked for beyond its footprint (a tall building's "
        "shadow at a low sun runs further, but the part nearest the footprint fixes the fit).",
        "geometry: a 6 m pole's shadow at 22 degrees",
    )
    footprint_margin_m: float = param(
        0.25,
        "m",
        "Ground within this distance of a footprint is left out: the contact shadow under a "
        "vehicle or person is dark in any light.",
        "geometry: a car's underbody overhangs its wheels' contact by about this much",
    )
    edge_px: int = param(
        2,
        "px",
        "Ground pixels within this distance of another surface or of anything not ground are "
        "left out (a kerb's face, an object's outline, anti-aliased edges).",
        "convention: the width of an anti-aliased edge plus one pixel",
    )
    reference_width_px: int = param(
        1024,
        "px",
        "The lit ground's luminance of each surface (its lit_percentile) is measured on every "
        "k-th row and column of the photo, k = its width // this (at least 1); the samples "
        "around the casters read their own pixels at full resolution.",
        "convention: 1024 is the synthetic set's width, where the light was tuned (k = 1 "
        "there: unchanged); a quarter of a 2048x1024 photo's ground pixels still holds "
        "hundreds of thousands for the percentile",
    )
    samples_per_side: int = param(
        24,
        "count",
        "Ground samples along each side of the square around a caster (its footprint plus the "
        "reach on every side); those in the ring within the reach and outside every footprint are used.",
        "convention: a few hundred samples in the ring around a car, under a metre apart",
    )
    min_shadow_share: float = param(
        0.005,
        "fraction",
        "Least share of the ground samples around the casters (each caster's ring weighing "
        "the same) that is shadowed in a sunny photo; less means overcast.",
        "geometry: a car's shadow under a sun 70 degrees high covers about 1 % of the ring its "
        "reach spans (the sunny synthetic scenes: 5 to 45 %; the overcast ones: 0)",
    )
    min_fit_iou: float = param(
        1.0 / 3.0,
        "fraction",
        "Least overlap (weighted intersection over union) of the surely predicted and the observed "
        "shadows for the fitted sun to be used (ground a top-cut caster's shadow may or may not "
        "reach counts as not predicted); a weaker fit gives the default sun (method weak_fit).",
        "geometry: two equal shadows overlapping by half their area have an IoU of 1/3 (the "
        "fit then explains no more of the shadows than it gets wrong)",
    )
    min_fit_casters: int = param(
        2,
        "count",
        "Least number of casters whose shadow at the fitted sun meets shadowed ground for the "
        "fit to be used; fewer gives the default sun (method weak_fit).",
        "geometry: one caster's shadow is one direction and one length, which one shadow of "
        "something unseen can mimic; two casters' shadows must agree",
    )
    unseen_top_spreads: float = param(
        2.0,
        "count",
        "An object whose top is cut by the image's top is at most its class's prior height "
        "plus this many of its height spreads (height_std_m in the class table) high; its "
        "shadow beyond that of its seen height is unknown up to that one's.",
        "convention: about 98 % of a normal population lies below its mean plus two standard "
        "deviations (buildings: 12 + 2 x 6 = 24 m); compared on the synthetic seeds 0-49 with "
        "the class's scale clamp (48 m): median sun error 18.3 / 7.7 deg against 16.8 / 10.5",
    )
    max_caster_range_m: float = param(
        40.0,
        "m",
        "Casters farther than this from the camera are not used (their shadows span a few "
        "pixels).",
        "convention: at 40 m a 2 m shadow spans about 1 % of a 60-degree view",
    )
    sky_top_fraction: float = param(
        0.25,
        "fraction",
        "The sky's zenith colour is the median of the top this fraction of sky pixels (by "
        "row), its horizon colour the median of the bottom this fraction.",
        "convention",
    )

    def __post_init__(self) -> None:
        if not self.sunny_min_contrast > 1.0:
            raise ValueError(f"light.sunny_min_contrast must be > 1, got {self.sunny_min_contrast}")
        lo, hi = self.elevation_range_deg
        if not 0.0 < lo < hi < 90.0:
            raise ValueError(f"light.elevation_range_deg must be 0 < lo < hi < 90, got {self.elevation_range_deg}")
        if not 0.0 < self.lit_percentile < 100.0:
            raise ValueError(f"light.lit_percentile must be in (0, 100), got {self.lit_percentile}")
        if not (self.coarse_step_deg > 0 and self.reach_max_m > 0 and self.samples_per_side >= 4):
            raise ValueError("light: coarse_step_deg and reach_max_m must be > 0, samples_per_side >= 4")
        if not self.reference_width_px >= 1:
            raise ValueError(f"light.reference_width_px must be >= 1, got {self.reference_width_px}")
        if not self.unseen_top_spreads >= 0.0:
            raise ValueError(f"light.unseen_top_spreads must be >= 0, got {self.unseen_top_spreads}")
        if not (0.0 <= self.min_fit_iou < 1.0 and self.min_fit_casters >= 1):
            raise ValueError("light: min_fit_iou must be in [0, 1) and min_fit_casters >= 1")
        if not 0.0 < self.sky_top_fraction <= 0.5:
            raise ValueError(f"light.sky_top_fraction must be in (0, 0.5], got {self.sky_top_fraction}")
