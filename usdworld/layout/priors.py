"""Metric class priors, read from ``usdworld/data/class_priors.json``."""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache

from usdworld.errors import InputError
from usdworld.resources import data_dir

#: How a class may be oriented (:func:`usdworld.layout.yaw.choose_yaw`).
YAW_MODES = ("road", "face_road", "camera", "none")


@dataclass(frozen=True)
class ClassPrior:
    """What a class usually measures.

    Attributes:
        name: placed class name.
        size_m: (length along the object's forward axis, width, height) in metres.
        height_std_m: spread of real heights, metres.
        scale_range: (min, max) uniform scale allowed relative to ``size_m``.
        yaw: ``road``, ``face_road``, ``camera`` or ``none``: how the object is oriented
            (:func:`usdworld.layout.yaw.choose_yaw`).
        kind: ``thing`` or ``stuff``.
        rigid_height: True when the height is reliable enough to calibrate the camera.
        facade_depth_m: for classes that face the road, the footprint's extent behind the
            facade (a photo shows only the front): it replaces the uniform scale's depth.
            None: the uniform scale's.
        frontage_range_m: for classes that face the road, the usual (min, max) frontage
            along the street, which sizes one running out of the image at a side. None:
            no such sizing.
    """

    name: str
    size_m: tuple[float, float, float]
    height_std_m: float
    scale_range: tuple[float, float]
    yaw: str
    kind: str
    rigid_height: bool
    facade_depth_m: float | None = None
    frontage_range_m: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        if any(s <= 0 for s in self.size_m) or not 0 < self.scale_range[0] <= 1 <= self.scale_range[1]:
            raise InputError(f"class_priors.json -> {self.name}: sizes must be > 0 and scale_range contain 1")
        if self.yaw not in YAW_MODES:
            raise InputError(f"class_priors.json -> {self.name} -> yaw: must be one of {', '.join(YAW_MODES)}")
        if self.facade_depth_m is not None and not self.facade_depth_m > 0:
            raise InputError(f"class_priors.json -> {self.name} -> facade_depth_m: must be > 0")
        if self.frontage_range_m is not None and not 0 < self.frontage_range_m[0] <= self.frontage_range_m[1]:
            raise InputError(
                f"class_priors.json -> {self.name} -> frontage_range_m: must be [min, max] with 0 < min <= max"
            )


@lru_cache(maxsize=1)
def class_priors() -> dict[str, ClassPrior]:
    """All class priors by placed class name."""
    raw = json.loads((data_dir() / "class_priors.json").read_text())
    priors = {}
    for name, entry in raw.items():
        if name.startswith("_"):
            continue
        priors[name] = ClassPrior(
            name=name,
            size_m=tuple(float(v) for v in entry["size_m"]),  # type: ignore[arg-type]
            height_std_m=float(entry["height_std_m"]),
            scale_range=tuple(float(v) for v in entry["scale_range"]),  # type: ignore[arg-type]
            yaw=str(entry["yaw"]),
            kind=str(entry["kind"]),
            rigid_height=bool(entry["rigid_height"]),
            facade_depth_m=float(entry["facade_depth_m"]) if "facade_depth_m" in entry else None,
            frontage_range_m=(
                tuple(float(v) for v in entry["frontage_range_m"])  # type: ignore[arg-type]
                if "frontage_range_m" in entry
                else None
            ),
        )
    return priors


def prior_for(class_name: str) -> ClassPrior:
    """The prior of one class; InputError naming the known classes otherwise."""
    priors = class_priors()
    if class_name not in priors:
        raise InputError(f"unknown class '{class_name}'; known classes: {', '.join(sorted(priors))}")
    return priors[class_name]
