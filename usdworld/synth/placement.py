"""Random placement of class assets along a :class:`StreetLayout`, without overlaps.

Every candidate object's footprint (its yawed bounding box, as an axis-aligned box in XY plus
a margin) is checked against everything placed before it; a candidate that overlaps is
dropped. Buildings go first, then street furniture and trees, parked cars, driving cars and people.
Things, trees and street furniture stand 4-60 m ahead of the camera (``THING_X_RANGE_M``);
buildings line the whole street.

Yaw is about world +Z, 0 = the asset's +X along world +X. Parked and driving cars face along
their lane's direction; signs and traffic lights face the camera; buildings and street lamps
face the road.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from usdworld.synth.assets import ClassAsset
from usdworld.synth.street import KERB_HEIGHT_M, StreetLayout

#: Along-road range (metres ahead of the camera) of cars, people, trees and street furniture.
THING_X_RANGE_M = (4.0, 60.0)
#: Along-road range of the building rows.
BUILDING_X_RANGE_M = (-25.0, 200.0)
#: Classes the sampler places (all must exist in the asset source).
SYNTH_CLASSES = ("building", "tree", "pole", "traffic_sign", "traffic_light", "car", "person")


def _frozen(values: object) -> np.ndarray:
    a = np.array(values, dtype=np.float64)
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class SynthObject:
    """One placed asset.

    Attributes:
        name: prim name under ``/World/Objects`` (``car_0003``).
        class_name: asset class.
        variant: the asset's ``model`` variant.
        centre_world: (3,) float64 (x, y, z_bottom): footprint centre on its support surface.
        yaw: radians about world +Z, in (-pi, pi].
        scale: (3,) float64 scale along the asset's axes.
        size_m: (3,) float64 (length, width, height) after scaling, metres.
        role: ``parked``, ``driving``, ``walking``, ``crossing``, ``street`` (furniture, buildings)
            or ``overtaking`` (:mod:`usdworld.synth.overtaking`).
    """

    name: str
    class_name: str
    variant: str
    centre_world: np.ndarray
    yaw: float
    scale: np.ndarray
    size_m: np.ndarray
    role: str

    def __post_init__(self) -> None:
        for field_name in ("centre_world", "scale", "size_m"):
            a = _frozen(getattr(self, field_name))
            if a.shape != (3,) or not np.all(np.isfinite(a)):
                raise ValueError(f"SynthObject.{field_name}: need 3 finite numbers, got {a}")
            object.__setattr__(self, field_name, a)

    def footprint_aabb(self, margin: float = 0.0) -> np.ndarray:
        """(4,) float64 ``xmin, ymin, xmax, ymax`` of the yawed footprint, grown by ``margin``."""
        return footprint_aabb(self.centre_world[:2], self.yaw, self.size_m[:2], margin)


def footprint_aabb(centre_xy: np.ndarray, yaw: float, size_lw: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """(4,) float64 axis-aligned box around a yawed rectangle (length along the heading)."""
    c, s = abs(math.cos(yaw)), abs(math.sin(yaw))
    hx = 0.5 * (size_lw[0] * c + size_lw[1] * s) + margin
    hy = 0.5 * (size_lw[0] * s + size_lw[1] * c) + margin
    return np.array([centre_xy[0] - hx, centre_xy[1] - hy, centre_xy[0] + hx, centre_xy[1] + hy])


def _wrap(angle: float) -> float:
    a = math.remainder(angle, 2.0 * math.pi)
    return math.pi if a == -math.pi else a


class _Placer:
    """Collects objects, refusing any whose footprint overlaps one already placed."""

    def __init__(self, rng: np.random.Generator, assets: dict[str, ClassAsset]) -> None:
        self.rng = rng
        self.assets = assets
        self.objects: list[SynthObject] = []
        self._boxes: list[np.ndarray] = []
        self._counts: dict[str, int] = {}

    def variant(self, class_name: str) -> str:
        variants = self.assets[class_name].variants
        return str(variants[int(self.rng.integers(0, len(variants)))])

    def size(self, class_name: str, variant: str) -> np.ndarray:
        return self.assets[class_name].size_by_variant[variant]

    def free(self, box: np.ndarray) -> bool:
        if not self._boxes:
            return True
        b = np.asarray(self._boxes)
        overlap = (b[:, 0] < box[2]) & (box[0] < b[:, 2]) & (b[:, 1] < box[3]) & (box[1] < b[:, 3])
        return not bool(overlap.any())

    def place(
        self,
        class_name: str,
        variant: str,
        centre: tuple[float, float, float],
        yaw: float,
        scale: np.ndarray | float,
        role: str,
        margin: float = 0.3,
    ) -> bool:
        scale_v = np.broadcast_to(np.asarray(scale, dtype=np.float64), (3,))
        size = self.size(class_name, variant) * scale_v
        yaw = _wrap(yaw)
        box = footprint_aabb(np.asarray(centre[:2]), yaw, size[:2], margin)
        if not self.free(box):
            return False
        k = self._counts.get(class_name, 0)
        self._counts[class_name] = k + 1
        self.objects.append(
            SynthObject(
                f"{class_name}_{k:04d}", class_name, variant, np.asarray(centre), yaw, scale_v, size, role
            )
        )
        self._boxes.append(footprint_aabb(np.asarray(centre[:2]), yaw, size[:2], 0.0))
        return True


def _sides(street: StreetLayout) -> tuple[tuple[float, float, float], ...]:
    """(kerb y, direction away from the road (-1 right, +1 left), sidewalk width) per side."""
    return (
        (street.kerb_right_y, -1.0, street.sidewalk_right_m),
        (street.kerb_left_y, 1.0, street.sidewalk_left_m),
    )


def _street_furniture(p: _Placer, street: StreetLayout, things: tuple[float, float]) -> None:
    rng = p.rng
    x0, x1 = things
    if street.crossing_x is not None:  # traffic lights before the crossing, facing the camera
        for kerb, away, _ in _sides(street):
            v = p.variant("traffic_light")
            p.place(
                "traffic_light",
                v,
                (street.crossing_x - 2.0, kerb + away * 0.5, KERB_HEIGHT_M),
                math.pi,
                float(rng.uniform(0.9, 1.1)),
                "street",
                margin=0.1,
            )
    for kerb, away, _ in _sides(street):  # street lamps, arm over the road
        x = float(rng.uniform(x0, x0 + 12.0))
        while x < x1:
            v = p.variant("pole")
            p.place(
                "pole",
                v,
                (x, kerb + away * 0.45, KERB_HEIGHT_M),
                -away * math.pi / 2,
                float(rng.uniform(0.9, 1.15)),
                "street",
                margin=0.2,
            )
            x += float(rng.uniform(18.0, 30.0))
    for _ in range(int(rng.integers(1, 4))):  # signs, mostly on the right
        kerb, away, _ = _sides(street)[0 if rng.random() < 0.75 else 1]
        v = p.variant("traffic_sign")
        x = float(rng.uniform(x0 + 2.0, x1 - 15.0))
        p.place(
            "traffic_sign",
            v,
            (x, kerb + away * 0.4, KERB_HEIGHT_M),
            math.pi + float(rng.normal(0, 0.1)),
            float(rng.uniform(0.9, 1.1)),
            "street",
            margin=0.2,
        )
    for kerb, away, width in _sides(street):  # trees near the kerb
        x = float(rng.uniform(x0, x0 + 8.0))
        while x < x1:
            if rng.random() < 0.75:
                v = p.variant("tree")
                s = float(rng.uniform(0.55, 0.9))
                r = 0.5 * float(p.size("tree", v)[:2].max()) * s
                offset = min(max(1.0, r - 0.6), width - 0.6)
                p.place(
                    "tree",
                    v,
                    (x, kerb + away * offset, KERB_HEIGHT_M),
                    float(rng.uniform(-math.pi, math.pi)),
                    s,
                    "street",
                    margin=0.1,
                )
            x += float(rng.uniform(7.0, 13.0))


def _buildings(p: _Placer, street: StreetLayout, extent: tuple[float, float]) -> None:
    rng = p.rng
    for kerb, away, width in _sides(street):
        outer = kerb + away * width
        x = extent[0] + float(rng.uniform(0.0, 5.0))
        while x < extent[1]:
            v = p.variant("building")
            size = p.size("building", v)
            frontage = float(rng.uniform(9.0, 24.0))
            depth = float(rng.uniform(9.0, 14.0))
            height = float(rng.uniform(7.0, 22.0))
            setback = float(rng.uniform(0.0, 0.6))
            # Facing the road: the asset's +X points across the street, so its length is the depth.
            yaw = -away * math.pi / 2
            scale = np.array([depth / size[0], frontage / size[1], height / size[2]])
            centre = (x + frontage / 2, outer + away * (setback + depth / 2), 0.0)
            p.place("building", v, centre, yaw, scale, "street", margin=0.0)
            gap = 0.0 if rng.random() < 0.55 else float(rng.uniform(1.0, 4.0))
            x += frontage + gap


def _parked_cars(p: _Placer, street: StreetLayout, things: tuple[float, float]) -> None:
    rng = p.rng
    for kerb, away, _ in _sides(street):
        strip = street.parking_right_m if away < 0 else street.parking_left_m
        if strip <= 0:
            continue
        heading = 0.0 if away < 0 else math.pi
        x = float(rng.uniform(things[0] - 1.0, things[0] + 4.0))
        while x < things[1]:
            v = p.variant("car")
            s = float(rng.uniform(0.95, 1.05))
            length = float(p.size("car", v)[0]) * s
            near_crossing = street.crossing_x is not None and abs(x + length / 2 - street.crossing_x) < 7.0
            if rng.random() < 0.75 and not near_crossing:
                y = kerb - away * (strip / 2 + float(rng.normal(0.0, 0.08)))
                if p.place(
                    "car",
                    v,
                    (x + length / 2, y, 0.0),
                    heading + float(rng.normal(0, 0.03)),
                    s,
                    "parked",
                    margin=0.25,
                ):
                    x += length + float(rng.uniform(0.7, 2.5))
                    continue
            x += float(rng.uniform(2.0, 6.0))


def _driving_cars(p: _Placer, street: StreetLayout, things: tuple[float, float]) -> None:
    rng = p.rng
    right, left = street.lane_centres_y()
    for lanes, heading in ((right, 0.0), (left, math.pi)):
        for y in lanes:
            for _ in range(int(rng.choice([0, 1, 1, 2]))):
                ego_lane = abs(y) < 0.5 * street.lane_width_m
                x = float(rng.uniform(14.0 if ego_lane else 8.0, things[1]))
                v = p.variant("car")
                p.place(
                    "car",
                    v,
                    (x, y + float(rng.normal(0, 0.15)), 0.0),
                    heading + float(rng.normal(0, 0.02)),
                    float(rng.uniform(0.95, 1.05)),
                    "driving",
                    margin=1.5,
                )


def _person_scale(p: _Placer, variant: str) -> float:
    height = float(np.clip(p.rng.normal(1.72, 0.09), 1.5, 1.95))
    return height / float(p.size("person", variant)[2])


def _people(p: _Placer, street: StreetLayout, things: tuple[float, float]) -> None:
    rng = p.rng
    if street.crossing_x is not None:
        for _ in range(int(rng.integers(0, 4))):
            v = p.variant("person")
            y = float(rng.uniform(street.kerb_right_y + 0.5, street.kerb_left_y - 0.5))
            x = street.crossing_x + float(rng.uniform(-1.2, 1.2))
            heading = (math.pi / 2 if rng.random() < 0.5 else -math.pi / 2) + float(rng.normal(0, 0.15))
            p.place("person", v, (x, y, 0.0), heading, _person_scale(p, v), "crossing", margin=0.15)
    for _ in range(int(rng.integers(4, 12))):
        kerb, away, width = _sides(street)[int(rng.integers(0, 2))]
        v = p.variant("person")
        s = _person_scale(p, v)
        for _attempt in range(6):
            x = float(rng.uniform(things[0] + 1.0, things[1] - 10.0))
            y = kerb + away * float(rng.uniform(0.6, width - 0.6))
            heading = (0.0 if rng.random() < 0.5 else math.pi) + float(rng.normal(0, 0.3))
            if p.place("person", v, (x, y, KERB_HEIGHT_M), heading, s, "walking", margin=0.15):
                break


def place_objects(
    rng: np.random.Generator,
    street: StreetLayout,
    assets: dict[str, ClassAsset],
    extend_m: float = 0.0,
) -> tuple[SynthObject, ...]:
    """Sample every object of a street scene.

    Args:
        rng: the random generator (consumed in a fixed order).
        street: the street cross-section.
        assets: class -> asset info, for every class of :data:`SYNTH_CLASSES`.
        extend_m: how much farther along +X things and buildings reach (a drive's length;
            0 for a single photo, whose draws it leaves unchanged).

    Returns:
        The objects in placement order (which is also their order on the stage).
    """
    placer = _Placer(rng, assets)
    things = (THING_X_RANGE_M[0], THING_X_RANGE_M[1] + extend_m)
    _buildings(placer, street, (BUILDING_X_RANGE_M[0], BUILDING_X_RANGE_M[1] + extend_m))
    _street_furniture(placer, street, things)
    _parked_cars(placer, street, things)
    _driving_cars(placer, street, things)
    _people(placer, street, things)
    return tuple(placer.objects)
