"""Sizes of the class assets by variant, and the choice of the variant an image shows."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from usdworld.layout.silhouette import top_offsets


@dataclass(frozen=True)
class AssetSizes:
    """Sizes of the class assets, by variant, as recorded in the library.

    Attributes:
        by_variant: (l, w, h) metres for each variant name.
        default_variant: the asset's default variant.
        contact_half_by_variant: half extents (along length, width) of the points where
            each variant touches the ground (a car's tyres, a person's feet), metres; the
            lowest image point of an object is its nearest contact point, not its bumper.
            Missing variants use half the footprint.
        top_half_by_variant: half extents of each variant's top (a car's roof), metres;
            the top row of a silhouette is the top's near or far edge. Missing variants
            use 0 (a top right above the centre).
        contact_mean_reach_by_variant: for objects whose heading is unknown (people), the
            mean over headings of how far the nearest contact lies from the centre, metres.
        top_shape_by_variant: each variant's side-view top shape
            (:func:`usdworld.perception.shape.top_shape_ratio`): a conifer's against a
            broad tree's, a plain pole's against a street lamp's.
    """

    by_variant: dict[str, tuple[float, float, float]]
    default_variant: str
    contact_half_by_variant: dict[str, tuple[float, float]] = field(default_factory=dict)
    top_half_by_variant: dict[str, tuple[float, float]] = field(default_factory=dict)
    contact_mean_reach_by_variant: dict[str, float] = field(default_factory=dict)
    top_shape_by_variant: dict[str, float] = field(default_factory=dict)

    def mean_reach(self, variant: str) -> float:
        """Mean distance of the nearest contact from the centre over all headings, unit scale
        (missing variants: the mean of the contact half extents)."""
        if variant in self.contact_mean_reach_by_variant:
            return float(self.contact_mean_reach_by_variant[variant])
        return float(np.mean(self.contact_half(variant)))

    def contact_half(self, variant: str) -> np.ndarray:
        """(2,) float64 contact half extents of a variant at unit scale."""
        if variant in self.contact_half_by_variant:
            return np.asarray(self.contact_half_by_variant[variant], dtype=np.float64)
        return 0.5 * np.asarray(self.by_variant[variant][:2], dtype=np.float64)

    def top_half(self, variant: str) -> np.ndarray:
        """(2,) float64 half extents of a variant's top at unit scale."""
        return np.asarray(self.top_half_by_variant.get(variant, (0.0, 0.0)), dtype=np.float64)

    def top_offsets(self, variant: str, rel_yaw: float, box_only: bool) -> tuple[float, float]:
        """Near and far edges of the variant's top beyond its lowest image point at unit
        scale, metres (:func:`usdworld.layout.silhouette.top_offsets`)."""
        size = np.asarray(self.by_variant[variant][:2], dtype=np.float64)
        return top_offsets(self.contact_half(variant), self.top_half(variant), size, rel_yaw, box_only)


def choose_variant(
    sizes: AssetSizes,
    measured_h: float,
    aspect: float,
    yaw_to_ray: float,
    top_shape: float | None,
    top_shape_offset: float,
) -> str:
    """The variant whose height, silhouette aspect and top shape best match the image.

    Args:
        sizes: the class's variants.
        measured_h: metric height seen in the image (NaN when cut).
        aspect: the mask's width / height in pixels (NaN when cut).
        yaw_to_ray: object yaw minus the viewing ray's bearing, radians.
        top_shape: the mask's :func:`usdworld.perception.shape.top_shape_ratio` (None when
            not usable); compared with the variants' side views.
        top_shape_offset: added to both top-shape ratios before their log ratio
            (``PlacementParams.top_shape_offset``), so that near-zero ratios (round tops)
            compare on a sane scale.

    Returns:
        The variant name; the default variant when nothing is measured or there is one.
    """
    shape_usable = top_shape is not None and len(sizes.top_shape_by_variant) == len(sizes.by_variant)
    if len(sizes.by_variant) < 2 or not (np.isfinite(measured_h) or np.isfinite(aspect) or shape_usable):
        return sizes.default_variant
    names = sorted(sizes.by_variant)
    errs = []
    for n in names:
        l, w, h = sizes.by_variant[n]
        err = abs(np.log(measured_h / h)) if np.isfinite(measured_h) else 0.0
        if np.isfinite(aspect) and aspect > 0:
            across = abs(l * np.sin(yaw_to_ray)) + abs(w * np.cos(yaw_to_ray))
            err += abs(np.log(aspect / (across / h)))
        if shape_usable:
            err += abs(
                np.log((top_shape + top_shape_offset) / (sizes.top_shape_by_variant[n] + top_shape_offset))
            )
        errs.append(err)
    return names[int(np.argmin(errs))]
