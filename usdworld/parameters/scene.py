"""Tuned numbers of the scene stage (see :mod:`usdworld.parameters.base` for the field conventions).

The scene stage is what ``build`` derives around the objects: the range it meshes, the
ground correspondences generated from a known camera, the road rows that bound the
horizon, the ground surfaces and the hidden ground filled in behind occluders.
"""

from __future__ import annotations

from dataclasses import dataclass

from usdworld.parameters.base import param


@dataclass(frozen=True)
class SceneParams:
    """Thresholds of the scene stage; each field documents its unit, meaning and origin."""

    max_range_m: float = param(
        80.0,
        "m",
        "Farthest ground distance meshed (road, sidewalk, terrain), and the farthest an object "
        "whose depth is only a bound from above (cut or hidden) may be placed. `--max-range` "
        "overrides it.",
        "convention: the part of the street a photo shows in useful detail",
    )
    road_top_min_fraction: float = param(
        0.005,
        "fraction",
        "An image row shows the road when at least this fraction of the image width is road; "
        "the highest such row bounds the horizon from below in the camera estimate.",
        "convention: ignores a few stray road pixels near the horizon",
    )
    road_top_min_px: int = param(
        2,
        "px",
        "The least road pixels a row needs to show the road, whatever the image width.",
        "convention: a single pixel is label noise",
    )
    surface_stride_px: int = param(
        4,
        "px",
        "Every this-many-th pixel (in rows and columns) of the road and sidewalk is mapped to "
        "the ground for the road axis and the sidewalk's kerb line; each sample sits at the "
        "centre of its cell.",
        "convention: thousands of points per surface at Cityscapes and KITTI sizes",
    )
    dlt_grid: tuple[int, int] = param(
        (4, 5),
        "count",
        "Pixel grid (rows, columns) of the ground correspondences generated from a known camera "
        "for the DLT homography.",
        "geometry: a homography has 8 degrees of freedom (4 points); 20 points spread over the "
        "ground rows condition the least-squares fit well",
    )
    dlt_horizon_margin: float = param(
        0.05,
        "fraction",
        "The generated correspondences start this fraction of the image height below the horizon "
        "(rows at the horizon map to infinity).",
        "convention",
    )
    fill_reach_m: float = param(
        8.0,
        "m",
        "How far behind a car, person or pole the hidden road or sidewalk is filled in.",
        "convention: about two car lengths; ground hidden further back stays a hole",
    )
    occluder_min_front_m: float = param(
        0.5,
        "m",
        "Least front depth of an occluder when the ground behind it is filled in (a footprint "
        "whose front would reach the camera).",
        "convention",
    )

    def __post_init__(self) -> None:
        if not self.max_range_m > 0:
            raise ValueError(f"scene.max_range_m must be > 0 m, got {self.max_range_m}")
