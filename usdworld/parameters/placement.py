"""Tuned numbers of the placement stage (see :mod:`usdworld.parameters.base` for the field conventions)."""

from __future__ import annotations

from dataclasses import dataclass

from usdworld.parameters.base import param


@dataclass(frozen=True)
class PlacementParams:
    """Thresholds of the placement stage; each field documents its unit, meaning and origin."""

    curb_height_m: float = param(
        0.15,
        "m",
        "Height of the kerb: objects standing on the sidewalk are lifted by this much, and a "
        "contact seen on the sidewalk is that much above the road plane the homography maps to.",
        "published: typical kerb height of urban streets, 0.1-0.2 m (e.g. FHWA, Manual on "
        "Uniform Traffic Control Devices; German RASt 06 gives 0.12-0.15 m)",
    )
