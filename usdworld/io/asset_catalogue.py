"""The asset catalogue: what layout knows of each class asset (sizes, variants, shape measures).

Layout sizes, chooses variants and reads silhouettes by the class assets' measures, but
reads no files: the pipeline (or the editor) reads the catalogue of the asset libraries
once (:func:`usdworld.authoring.asset_measures.asset_catalogue`, which opens the USD
files) and passes it in as this plain, frozen data. Frames: each asset's own (metres,
Z up, +X forward, origin at the centre of the footprint's bottom face).

Example:
    >>> car = AssetSizes({"hatchback": (4.0, 1.8, 1.5)}, "hatchback")
    >>> catalogue = AssetCatalogue({"car": car})
    >>> catalogue["car"].contact_half("hatchback").tolist()
    [2.0, 0.9]
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field

import numpy as np

from usdworld.errors import InputError


@dataclass(frozen=True)
class AssetSizes:
    """Sizes and shape measures of one class asset, by variant, at unit scale.

    Attributes:
        by_variant: (l, w, h) metres for each variant name ('' for an asset without variants).
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
        contact_offset_by_variant: (x, y) centre of each variant's ground contact's extent,
            metres: a street lamp's mast stands behind its origin (the centre of a footprint
            that spans the arm). Missing variants use (0, 0).
    """

    by_variant: dict[str, tuple[float, float, float]]
    default_variant: str
    contact_half_by_variant: dict[str, tuple[float, float]] = field(default_factory=dict)
    top_half_by_variant: dict[str, tuple[float, float]] = field(default_factory=dict)
    contact_mean_reach_by_variant: dict[str, float] = field(default_factory=dict)
    top_shape_by_variant: dict[str, float] = field(default_factory=dict)
    contact_offset_by_variant: dict[str, tuple[float, float]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.default_variant not in self.by_variant:
            raise InputError(
                f"asset sizes: default variant '{self.default_variant}' has no size; "
                f"sized variants: {sorted(self.by_variant)}"
            )
        for name in (
            "contact_half_by_variant",
            "top_half_by_variant",
            "contact_mean_reach_by_variant",
            "top_shape_by_variant",
            "contact_offset_by_variant",
        ):
            extra = sorted(set(getattr(self, name)) - set(self.by_variant))
            if extra:
                raise InputError(f"asset sizes -> {name}: variant(s) {extra} have no size")

    def mean_reach(self, variant: str) -> float:
        """Mean distance of the nearest contact from the centre over all headings, unit scale
        (missing variants: the mean of the contact half extents)."""
        if variant in self.contact_mean_reach_by_variant:
            return float(self.contact_mean_reach_by_variant[variant])
        return float(np.mean(self.contact_half(variant)))

    def footprint(self, variant: str) -> np.ndarray:
        """(2,) float64 length and width of a variant's footprint at unit scale, metres."""
        return np.asarray(self.by_variant[variant][:2], dtype=np.float64)

    def contact_half(self, variant: str) -> np.ndarray:
        """(2,) float64 contact half extents of a variant at unit scale."""
        if variant in self.contact_half_by_variant:
            return np.asarray(self.contact_half_by_variant[variant], dtype=np.float64)
        return 0.5 * np.asarray(self.by_variant[variant][:2], dtype=np.float64)

    def contact_offset(self, variant: str) -> np.ndarray:
        """(2,) float64 centre of a variant's ground contact in its frame at unit scale, metres."""
        return np.asarray(self.contact_offset_by_variant.get(variant, (0.0, 0.0)), dtype=np.float64)

    def contact_own_half(self, variant: str) -> np.ndarray:
        """(2,) float64 half extents of a variant's ground contact about its own centre
        (:meth:`contact_offset`), unit scale: a street lamp's mast's, not mast to arm."""
        return np.maximum(self.contact_half(variant) - np.abs(self.contact_offset(variant)), 0.0)

    def top_half(self, variant: str) -> np.ndarray:
        """(2,) float64 half extents of a variant's top at unit scale."""
        return np.asarray(self.top_half_by_variant.get(variant, (0.0, 0.0)), dtype=np.float64)


@dataclass(frozen=True)
class AssetCatalogue(Mapping[str, AssetSizes]):
    """The sizes of the class assets a build uses, by class name; a read-only mapping.

    Attributes:
        sizes: class name -> its asset's sizes.
    """

    sizes: Mapping[str, AssetSizes] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "sizes", dict(self.sizes))

    def __getitem__(self, class_name: str) -> AssetSizes:
        try:
            return self.sizes[class_name]
        except KeyError:
            known = ", ".join(sorted(self.sizes)) or "none"
            raise InputError(f"asset catalogue: no asset for class '{class_name}'; catalogued: {known}") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self.sizes)

    def __len__(self) -> int:
        return len(self.sizes)
