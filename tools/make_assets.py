"""Generate the built-in class asset library (``asset_library/``), reproducibly.

Usage::

    python tools/make_assets.py              # rewrite asset_library/
    python tools/make_assets.py --check      # exit 1 if asset_library/ differs from what would be generated
    python tools/make_assets.py --out DIR    # write the library into DIR instead
    python tools/make_assets.py --only car   # regenerate some classes only

One asset per class of ``usdworld/data/class_priors.json``. The default variant's bounding box
equals the class's ``size_m`` = (length along +X, width along Y, height along Z) in metres; the
origin is the centre of the bounding box's bottom face; the object faces +X, Z is up.

Each class is written as two files:

``<class>.usda``
    The asset proper (text, reviewed like code): stage metadata, the ``/<class>`` component root
    with its ``class`` semantic label and ``usdworld:*`` customData, a typed ``Geom`` Xform, the
    variant set ``model`` holding one Mesh per material (extent, displayColor, material binding,
    label) and the UsdPreviewSurface materials under ``Looks``.
``<class>.geom.usdc``
    A sublayer of ``<class>.usda`` holding only the long arrays (points, face counts and indices,
    normals) as overs inside the same variants. omni-asset-validator's UsdAsciiPerformanceChecker
    fails every ``.usda`` layer that holds an array longer than 64 elements, so mesh arrays must
    live in a crate layer. Copy both files together.
``<class>.card.json``
    The asset's card (:mod:`usdworld.authoring.asset_cards`): its variants, sizes and shape
    measures with a digest of the two files above, so builds and edits need not measure it,
    and the errors each validator (UsdValidation, omni-asset-validator where installed, with
    their versions) found in every variant, so exports need not validate the asset again.

Geometry is modelled with manifold3d constructive solid geometry (one closed, manifold solid per
material), shaded with faceVarying normals smoothed only across edges sharper than
``CREASE_DEG``, and finished with trimesh checks. Output is byte-identical run to run: no
timestamps, no absolute paths, fixed tessellation, coordinates rounded to 10 um.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh
from manifold3d import CrossSection, JoinType, Manifold, OpType
from pxr import Gf, Sdf, Usd, UsdGeom, UsdSemantics, UsdShade, Vt

from usdworld.authoring.asset_cards import CARD_SUFFIX, write_card
from usdworld.authoring.asset_library import TAXONOMY, VARIANT_SET, define_asset_root
from usdworld.authoring.asset_measures import asset_card_text
from usdworld.authoring.validate import validate_asset, validation_record
from usdworld.authoring.shading import crease_normals, extent

REPO = Path(__file__).resolve().parents[1]
PRIORS_PATH = REPO / "usdworld" / "data" / "class_priors.json"
DEFAULT_OUT = REPO / "asset_library"
CREATOR = "usdworld tools/make_assets.py"


#: Points are rounded to this many decimals (metres) so output does not depend on float noise.
POINT_DECIMALS = 5
#: How far the built default variant may be from size_m before it is scaled to fit (a design check).
MAX_FIT_CORRECTION = 0.06

Vec3 = tuple[float, float, float]


# --------------------------------------------------------------------------------------------
# Materials
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Material:
    """A UsdPreviewSurface look; ``color`` is linear RGB and also the mesh's displayColor."""

    color: Vec3
    roughness: float = 0.6
    metallic: float = 0.0


PALETTE: dict[str, Material] = {
    # vehicles
    "paint_red": Material((0.50, 0.04, 0.03), 0.35),
    "paint_blue": Material((0.03, 0.09, 0.30), 0.35),
    "paint_white": Material((0.80, 0.80, 0.78), 0.4),
    "paint_yellow": Material((0.75, 0.45, 0.02), 0.4),
    "paint_green": Material((0.05, 0.25, 0.08), 0.4),
    "glass": Material((0.02, 0.03, 0.04), 0.05),
    "tyre": Material((0.02, 0.02, 0.02), 0.9),
    "rim": Material((0.55, 0.55, 0.57), 0.3, 1.0),
    "trim": Material((0.03, 0.03, 0.03), 0.7),
    "headlight": Material((0.90, 0.88, 0.75), 0.1),
    "taillight": Material((0.55, 0.01, 0.01), 0.2),
    "chassis": Material((0.05, 0.05, 0.05), 0.8, 0.5),
    "display": Material((0.80, 0.45, 0.02), 0.3),
    "roof": Material((0.45, 0.45, 0.45), 0.6),
    "stripe": Material((0.60, 0.02, 0.02), 0.4),
    "door": Material((0.30, 0.30, 0.32), 0.4),
    "bogie": Material((0.04, 0.04, 0.04), 0.7, 0.5),
    "wheel_steel": Material((0.35, 0.35, 0.36), 0.4, 1.0),
    "engine": Material((0.10, 0.10, 0.11), 0.5, 0.8),
    "seat": Material((0.02, 0.015, 0.01), 0.8),
    "metal": Material((0.50, 0.50, 0.52), 0.35, 1.0),
    "frame_blue": Material((0.02, 0.12, 0.45), 0.35),
    # people
    "skin": Material((0.55, 0.33, 0.22), 0.7),
    "hair": Material((0.04, 0.025, 0.015), 0.8),
    "shirt": Material((0.10, 0.25, 0.45), 0.8),
    "jacket": Material((0.45, 0.10, 0.04), 0.8),
    "trousers": Material((0.05, 0.06, 0.10), 0.85),
    "shoes": Material((0.03, 0.03, 0.03), 0.7),
    "helmet": Material((0.70, 0.70, 0.05), 0.3),
    # things and stuff
    "wood": Material((0.40, 0.25, 0.12), 0.9),
    "wood_light": Material((0.55, 0.40, 0.22), 0.9),
    "cardboard": Material((0.50, 0.33, 0.16), 0.9),
    "tape": Material((0.70, 0.60, 0.40), 0.5),
    "bark": Material((0.18, 0.11, 0.06), 0.95),
    "leaves": Material((0.06, 0.22, 0.04), 0.9),
    "needles": Material((0.02, 0.12, 0.04), 0.9),
    "wall": Material((0.65, 0.55, 0.45), 0.9),
    "window": Material((0.05, 0.08, 0.12), 0.1),
    "curtain_wall": Material((0.10, 0.18, 0.26), 0.1, 0.3),
    "concrete": Material((0.45, 0.45, 0.43), 0.9),
    "roof_tiles": Material((0.35, 0.08, 0.05), 0.8),
    "mullion": Material((0.12, 0.12, 0.13), 0.5, 0.8),
    "pole_metal": Material((0.40, 0.40, 0.42), 0.4, 1.0),
    "lamp": Material((0.95, 0.90, 0.70), 0.2),
    "housing": Material((0.03, 0.04, 0.03), 0.6),
    "lamp_red": Material((0.80, 0.02, 0.01), 0.2),
    "lamp_amber": Material((0.85, 0.45, 0.01), 0.2),
    "lamp_green": Material((0.02, 0.60, 0.15), 0.2),
    "sign_red": Material((0.60, 0.02, 0.02), 0.4),
    "sign_white": Material((0.85, 0.85, 0.85), 0.4),
    "sign_blue": Material((0.02, 0.10, 0.50), 0.4),
    "sign_back": Material((0.30, 0.30, 0.31), 0.5, 0.8),
}


# --------------------------------------------------------------------------------------------
# Solid-modelling kit (manifold3d). All lengths in metres, asset frame: +X forward, Y left, Z up.
# --------------------------------------------------------------------------------------------


def box(x0: float, x1: float, y0: float, y1: float, z0: float, z1: float) -> Manifold:
    """Axis-aligned box between the given bounds."""
    return Manifold.cube((x1 - x0, y1 - y0, z1 - z0)).translate((x0, y0, z0))


def blob(centres: Iterable[Sequence[float]], r: float, seg: int = 8) -> Manifold:
    """Convex hull of spheres of radius ``r`` at ``centres``: rounded boxes, wedges, limbs."""
    return Manifold.batch_hull([Manifold.sphere(r, seg).translate(tuple(map(float, c))) for c in centres])


def corners(x0: float, x1: float, y0: float, y1: float, z0: float, z1: float) -> list[Vec3]:
    """The eight corners of a box."""
    return [(x, y, z) for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)]


def rbox(
    x0: float, x1: float, y0: float, y1: float, z0: float, z1: float, r: float, seg: int = 8
) -> Manifold:
    """Box with edges rounded by ``r`` (exact outer bounds)."""
    return blob(corners(x0 + r, x1 - r, y0 + r, y1 - r, z0 + r, z1 - r), r, seg)


def mirror_y(points: Iterable[Vec3]) -> list[Vec3]:
    """Each point and its mirror image across the XZ plane."""
    out: list[Vec3] = []
    for x, y, z in points:
        out += [(x, y, z), (x, -y, z)]
    return out


def rod(p0: Sequence[float], p1: Sequence[float], r0: float, r1: float = -1.0, seg: int = 12) -> Manifold:
    """Cylinder (or cone frustum when ``r1`` >= 0) from ``p0`` to ``p1``."""
    a, b = np.asarray(p0, float), np.asarray(p1, float)
    d = b - a
    h = float(np.linalg.norm(d))
    w = d / h
    helper = np.array([1.0, 0.0, 0.0]) if abs(w[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(helper, w)
    u /= np.linalg.norm(u)
    v = np.cross(w, u)
    m = np.column_stack([u, v, w, a])
    return Manifold.cylinder(h, r0, r1, seg).transform(m)


def capsule(p0: Sequence[float], p1: Sequence[float], r: float, seg: int = 12) -> Manifold:
    """Rod with hemispherical ends (limbs, handles)."""
    return blob([p0, p1], r, seg)


def ball(c: Sequence[float], r: float, seg: int = 12, scale: Vec3 = (1.0, 1.0, 1.0)) -> Manifold:
    """Sphere (ellipsoid when ``scale`` is not 1) centred at ``c``."""
    return Manifold.sphere(r, seg).scale(scale).translate(tuple(map(float, c)))


def ring_y(c: Vec3, big_r: float, small_r: float, seg: int = 32, seg_small: int = 8) -> Manifold:
    """Torus around an axis parallel to Y (bicycle and motorcycle tyres)."""
    section = CrossSection.circle(small_r, seg_small).translate((big_r, 0.0))
    return Manifold.revolve(section, seg).rotate((90.0, 0.0, 0.0)).translate(c)


def _ccw(points: Sequence[Sequence[float]]) -> np.ndarray:
    p = np.asarray(points, float)
    area = 0.5 * float(np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1]))
    return p if area > 0 else p[::-1].copy()


def section(points: Sequence[Sequence[float]]) -> CrossSection:
    """A 2D polygon (either winding)."""
    return CrossSection([_ccw(points)])


def prism_xz(profile: CrossSection | Sequence[Sequence[float]], y0: float, y1: float) -> Manifold:
    """Extrude a side profile given in (x, z) across Y from ``y0`` to ``y1``."""
    cs = profile if isinstance(profile, CrossSection) else section(profile)
    m = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, y1], [0.0, 1.0, 0.0, 0.0]])
    return Manifold.extrude(cs, y1 - y0).transform(m)


def union(solids: Sequence[Manifold]) -> Manifold:
    """Boolean union of solids."""
    return Manifold.batch_boolean(list(solids), OpType.Add)


def wheel_y(x: float, y_in: float, y_out: float, z: float, r: float, seg: int = 20) -> Manifold:
    """A cylinder along Y between ``y_in`` and ``y_out`` (sign gives the side)."""
    return rod((x, y_in, z), (x, y_out, z), r, seg=seg)


class Model:
    """Solids of one variant, grouped by material name (one Mesh prim per material)."""

    def __init__(self, overrides: dict[str, Material] | None = None) -> None:
        self.parts: dict[str, list[Manifold]] = {}
        self.overrides = dict(overrides or {})

    def add(self, material: str, *solids: Manifold) -> None:
        if material not in PALETTE and material not in self.overrides:
            raise KeyError(f"unknown material '{material}'; add it to PALETTE")
        self.parts.setdefault(material, []).extend(solids)

    def material(self, name: str) -> Material:
        return self.overrides.get(name, PALETTE.get(name))  # type: ignore[return-value]

    def rotated_z(self, degrees: float) -> "Model":
        """The same model turned about the vertical axis."""
        out = Model(self.overrides)
        out.parts = {k: [s.rotate((0.0, 0.0, degrees)) for s in v] for k, v in self.parts.items()}
        return out


# --------------------------------------------------------------------------------------------
# Shared sub-assemblies
# --------------------------------------------------------------------------------------------


def add_car_wheels(
    m: Model, axles_x: Sequence[float], half_w: float, r: float, width: float, rim: str = "rim"
) -> None:
    """Four (or more) wheels: tyre cylinder plus a rim disc proud of its outer face."""
    for x in axles_x:
        for s in (1.0, -1.0):
            m.add("tyre", wheel_y(x, s * (half_w - width), s * half_w, r, r, seg=20))
            m.add(rim, wheel_y(x, s * (half_w - width + 0.01), s * (half_w + 0.006), r, 0.58 * r, seg=16))


def arches(axles_x: Sequence[float], half_w: float, r: float, depth: float) -> Manifold:
    """Wheel-arch cutters on both sides (cylinders along Y)."""
    cuts = []
    for x in axles_x:
        for s in (1.0, -1.0):
            cuts.append(wheel_y(x, s * (half_w - depth), s * (half_w + 0.05), r, r, seg=20))
    return union(cuts)


def pillar_cuts(xs: Iterable[float], width: float, half_w: float, z0: float, z1: float) -> Manifold:
    """Slabs that cut window bands into panes at ``xs`` on both sides (|y| > 0.35 m)."""
    cuts = []
    for x in xs:
        for s in (1.0, -1.0):
            y0, y1 = sorted((s * 0.35, s * (half_w + 0.1)))
            cuts.append(box(x - width / 2, x + width / 2, y0, y1, z0, z1))
    return union(cuts)


def add_bicycle(m: Model, frame: str = "frame_blue") -> dict[str, Vec3]:
    """A 28-inch bicycle, 1.75 m long, facing +X; returns contact points for a rider."""
    wheel_x, wheel_r = 0.525, 0.35
    for x in (-wheel_x, wheel_x):
        m.add("tyre", ring_y((x, 0.0, wheel_r), 0.33, 0.02, 28, 6))
        m.add("metal", ring_y((x, 0.0, wheel_r), 0.305, 0.01, 28, 4))
        m.add("metal", rod((x, -0.05, wheel_r), (x, 0.05, wheel_r), 0.03, seg=10))
        for k in range(8):
            angle = math.pi * k / 4 + math.pi / 8
            tip = (x + 0.30 * math.cos(angle), 0.0, wheel_r + 0.30 * math.sin(angle))
            m.add("metal", rod((x, 0.0, wheel_r), tip, 0.004, seg=4))
    rear_axle, front_axle = (-wheel_x, 0.0, wheel_r), (wheel_x, 0.0, wheel_r)
    bb, seat_top = (-0.08, 0.0, 0.30), (-0.25, 0.0, 0.85)
    head_top, head_bottom = (0.36, 0.0, 0.83), (0.40, 0.0, 0.67)
    tubes = [(bb, seat_top), (seat_top, head_top), (bb, head_bottom)]
    for start, end in tubes:
        m.add(frame, rod(start, end, 0.018, seg=10))
    m.add(frame, rod(head_bottom, head_top, 0.024, seg=10))
    for s in (1.0, -1.0):
        m.add(frame, rod((rear_axle[0], s * 0.035, wheel_r), (bb[0], s * 0.02, bb[2]), 0.012, seg=8))
        m.add(
            frame,
            rod(
                (rear_axle[0], s * 0.03, wheel_r), (seat_top[0], s * 0.015, seat_top[2] - 0.03), 0.011, seg=8
            ),
        )
        m.add(
            frame,
            rod(
                (head_bottom[0], s * 0.045, head_bottom[2]), (front_axle[0], s * 0.045, wheel_r), 0.013, seg=8
            ),
        )
    seat_post = (-0.29, 0.0, 0.98)
    m.add("metal", rod(seat_top, seat_post, 0.013, seg=8))
    m.add(
        "seat",
        blob([(-0.38, 0.06, 1.0), (-0.38, -0.06, 1.0), (-0.17, 0.012, 1.0), (-0.17, -0.012, 1.0)], 0.03, 8),
    )
    bar_z, bar_x = 1.07, 0.32
    m.add("metal", rod(head_top, (0.345, 0.0, bar_z), 0.016, seg=8))
    m.add("metal", rod((bar_x, -0.3, bar_z), (bar_x, 0.3, bar_z), 0.012, seg=8))
    for s in (1.0, -1.0):
        m.add("seat", rod((bar_x, s * 0.2, bar_z), (bar_x, s * 0.3, bar_z), 0.018, seg=8))
    m.add("metal", rod((bb[0], 0.045, bb[2]), (bb[0], 0.055, bb[2]), 0.10, seg=20))
    pedal_f, pedal_r = (bb[0] + 0.17, -0.09, bb[2]), (bb[0] - 0.17, 0.09, bb[2])
    m.add("metal", rod((bb[0], -0.07, bb[2]), pedal_f, 0.012, seg=6))
    m.add("metal", rod((bb[0], 0.07, bb[2]), pedal_r, 0.012, seg=6))
    for p in (pedal_f, pedal_r):
        m.add(
            "trim",
            box(
                p[0] - 0.05,
                p[0] + 0.05,
                p[1] - 0.05 if p[1] < 0 else p[1],
                p[1] if p[1] < 0 else p[1] + 0.05,
                p[2] - 0.012,
                p[2] + 0.012,
            ),
        )
    return {
        "saddle": (-0.26, 0.0, 1.03),
        "grip_left": (bar_x, 0.26, bar_z),
        "grip_right": (bar_x, -0.26, bar_z),
        "pedal_front": (pedal_f[0], -0.12, pedal_f[2] + 0.03),
        "pedal_rear": (pedal_r[0], 0.12, pedal_r[2] + 0.03),
    }


@dataclass(frozen=True)
class Pose:
    """Joint positions of a person (metres, asset frame); ``l``/``r`` = left (+Y) / right (-Y)."""

    head: Vec3
    neck: Vec3
    shoulders: tuple[Vec3, Vec3]
    waist: tuple[Vec3, Vec3]
    hips: tuple[Vec3, Vec3]
    knees: tuple[Vec3, Vec3]
    ankles: tuple[Vec3, Vec3]
    toes: tuple[Vec3, Vec3]
    elbows: tuple[Vec3, Vec3]
    wrists: tuple[Vec3, Vec3]
    hands: tuple[Vec3, Vec3]


def add_person(m: Model, p: Pose, top: str = "shirt", headwear: str = "hair") -> None:
    """A low-poly person: head, hair or helmet, neck, torso, pelvis, arms, hands, legs, shoes."""
    hx, hy, hz = p.head
    m.add("skin", ball(p.head, 0.1, 16, (0.95, 0.85, 1.1)))
    cap = ball(p.head, 0.106, 16, (0.98, 0.9, 1.1))
    if headwear == "hair":
        keep = union(
            [
                box(hx - 0.2, hx + 0.2, hy - 0.2, hy + 0.2, hz + 0.015, hz + 0.2),
                box(hx - 0.2, hx - 0.035, hy - 0.2, hy + 0.2, hz - 0.08, hz + 0.2),
            ]
        )
        m.add("hair", cap ^ keep)
    else:
        m.add(
            "helmet",
            ball(p.head, 0.118, 16, (1.05, 0.9, 1.0))
            ^ box(hx - 0.2, hx + 0.2, hy - 0.2, hy + 0.2, hz + 0.0, hz + 0.2),
        )
    m.add("skin", capsule(p.neck, (hx - 0.01, hy, hz - 0.05), 0.045, 10))
    (sl, sr), (wl, wr) = p.shoulders, p.waist
    torso = [(x + dx, y, z) for (x, y, z) in (sl, sr, wl, wr) for dx in (-0.035, 0.035)]
    m.add(top, blob(torso, 0.085, 12))
    hl, hr = p.hips
    pelvis = [(x + dx, y, z + dz) for (x, y, z) in (hl, hr) for dx in (-0.03, 0.03) for dz in (-0.02, 0.08)]
    m.add("trousers", blob(pelvis, 0.075, 12))
    for side in (0, 1):
        m.add(
            "trousers",
            capsule(p.hips[side], p.knees[side], 0.068, 12),
            capsule(p.knees[side], p.ankles[side], 0.054, 12),
        )
        ax, ay, az = p.ankles[side]
        tx, ty, tz = p.toes[side]
        m.add("shoes", blob([(ax - 0.035, ay, az - 0.02), (ax + 0.01, ay, az + 0.0), (tx, ty, tz)], 0.045, 8))
        m.add(top, capsule(p.shoulders[side], p.elbows[side], 0.047, 10))
        m.add(
            "skin",
            capsule(p.elbows[side], p.wrists[side], 0.038, 10),
            ball(p.hands[side], 0.048, 8, (1.0, 0.7, 1.2)),
        )


# --------------------------------------------------------------------------------------------
# Class builders: each returns the Model of one variant.
# --------------------------------------------------------------------------------------------


def _car(
    length: float,
    width: float,
    height: float,
    paint: str,
    wheel_r: float,
    wheelbase: float,
    z_bottom: float,
    z_belt: float,
    z_hood: float,
    cabin_bottom: tuple[float, float],
    cabin_top: tuple[float, float],
    cabin_half_w: tuple[float, float],
    roof_rails: bool,
) -> Model:
    m = Model()
    hl, hw, r = length / 2, width / 2, 0.08
    front_axle = hl - (length - wheelbase) / 2 + 0.02
    axles = (front_axle, front_axle - wheelbase)
    body = blob(
        mirror_y(
            [
                (-hl + r, hw - r, z_bottom + r),
                (hl - r, hw - r, z_bottom + r),
                (-hl + r, hw - r, z_belt - r),
                (hl - r, hw - r, z_hood - r),
            ]
        ),
        r,
    )
    rc = 0.06
    roof_z = height - rc - (0.05 if roof_rails else 0.0)
    cabin_pts = mirror_y(
        [
            (cabin_bottom[0] + rc, cabin_half_w[0] - rc, z_belt - 0.1),
            (cabin_bottom[1] - rc, cabin_half_w[0] - rc, z_belt - 0.1),
            (cabin_top[0] + rc, cabin_half_w[1] - rc, roof_z),
            (cabin_top[1] - rc, cabin_half_w[1] - rc, roof_z),
        ]
    )
    cabin = blob(cabin_pts, rc)
    m.add(paint, (body + cabin) - arches(axles, hw, wheel_r + 0.05, 0.3))
    band = box(-hl, hl, -hw, hw, z_belt + 0.04, roof_z + rc - 0.09)
    b_pillar = 0.5 * (cabin_top[0] + cabin_top[1]) - 0.05
    glass = (blob(cabin_pts, rc + 0.012) ^ band) - pillar_cuts(
        [b_pillar, cabin_top[0] + 0.12], 0.09, hw, 0.0, height + 1
    )
    m.add("glass", glass)
    add_car_wheels(m, axles, hw - 0.02, wheel_r, 0.2)
    for s in (1.0, -1.0):
        y0, y1 = sorted((s * (hw - 0.38), s * (hw - 0.1)))
        m.add("headlight", box(hl - 0.04, hl + 0.004, y0, y1, z_hood - 0.2, z_hood - 0.1))
        y0, y1 = sorted((s * (hw - 0.3), s * (hw - 0.1)))
        m.add("taillight", box(-hl - 0.004, -hl + 0.04, y0, y1, z_belt - 0.3, z_belt - 0.13))
    trim = [
        box(hl - 0.03, hl + 0.004, -(hw - 0.45), hw - 0.45, z_bottom + 0.17, z_hood - 0.12),
        box(hl - 0.05, hl + 0.006, -(hw - 0.12), hw - 0.12, z_bottom + 0.04, z_bottom + 0.15),
        box(-hl - 0.006, -hl + 0.05, -(hw - 0.12), hw - 0.12, z_bottom + 0.04, z_bottom + 0.15),
    ]
    if roof_rails:
        for s in (1.0, -1.0):
            y0, y1 = sorted((s * (cabin_half_w[1] - 0.13), s * (cabin_half_w[1] - 0.08)))
            trim.append(box(cabin_top[0] + 0.1, cabin_top[1] - 0.1, y0, y1, roof_z + rc - 0.02, height))
    m.add("trim", *trim)
    return m


def car_hatchback() -> Model:
    return _car(
        4.2,
        1.8,
        1.5,
        "paint_red",
        0.31,
        2.55,
        0.2,
        0.95,
        0.78,
        (-2.02, 0.85),
        (-1.62, -0.15),
        (0.84, 0.66),
        roof_rails=False,
    )


def car_suv() -> Model:
    return _car(
        4.65,
        1.9,
        1.75,
        "paint_blue",
        0.37,
        2.8,
        0.32,
        1.12,
        1.0,
        (-2.25, 0.85),
        (-2.2, 0.1),
        (0.9, 0.74),
        roof_rails=True,
    )


def car_sedan() -> Model:
    return _car(
        4.7,
        1.82,
        1.45,
        "paint_white",
        0.32,
        2.8,
        0.2,
        0.92,
        0.8,
        (-1.6, 0.95),
        (-1.1, 0.15),
        (0.85, 0.66),
        roof_rails=False,
    )


def truck_box() -> Model:
    m = Model()
    hw = 1.25
    axles = (3.0, -1.8, -3.0)
    cargo = rbox(-4.0, 1.85, -hw, hw, 0.95, 3.2, 0.04, 4) - arches(axles[1:], hw, 0.56, 0.6)
    ribs = [box(x, x + 0.06, -hw - 0.004, hw + 0.004, 1.0, 3.15) for x in np.arange(-3.6, 1.8, 0.9)]
    m.add("paint_white", union([cargo, *ribs]))
    r = 0.1
    cab_pts = mirror_y(
        [
            (2.0 + r, 1.2 - r, 0.7 + r),
            (4.0 - r, 1.2 - r, 0.7 + r),
            (2.0 + r, 1.2 - r, 3.0 - r),
            (3.8 - r, 1.2 - r, 3.0 - r),
        ]
    )
    m.add("paint_red", blob(cab_pts, r) - arches(axles[:1], 1.2, 0.56, 0.6))
    m.add(
        "glass",
        (blob(cab_pts, r + 0.012) ^ box(2.7, 4.2, -2, 2, 1.75, 2.75)) - pillar_cuts([3.3], 0.1, 1.2, 0, 4),
    )
    m.add(
        "chassis",
        box(-3.8, 3.7, -0.5, 0.5, 0.6, 0.95),
        box(-3.98, -3.8, -1.1, 1.1, 0.55, 0.72),
        box(3.85, 4.01, -1.2, 1.2, 0.5, 0.78),
    )
    m.add("trim", box(3.96, 4.012, -0.8, 0.8, 0.95, 1.6))
    for s in (1.0, -1.0):
        y0, y1 = sorted((s * 0.85, s * 1.1))
        m.add("headlight", box(3.96, 4.014, y0, y1, 1.0, 1.2))
        m.add("taillight", box(-4.0, -3.97, y0, y1, 0.6, 0.7))
    add_car_wheels(m, axles[:1], 1.2, 0.5, 0.3)
    add_car_wheels(m, axles[1:], 1.22, 0.5, 0.55)
    return m


def bus_city() -> Model:
    m = Model()
    hl, hw, z0, z1, r = 5.5, 1.275, 0.3, 3.05, 0.15
    axles = (2.9, -2.4)
    body = rbox(-hl, hl, -hw, hw, z0, z1, r)
    m.add("paint_yellow", body - arches(axles, hw, 0.58, 0.55))
    shell = rbox(-hl - 0.012, hl + 0.012, -hw - 0.012, hw + 0.012, z0 - 0.012, z1 + 0.012, r + 0.012)
    band = (shell ^ box(-hl + 0.5, hl - 0.3, -2, 2, 1.25, 2.65)) - pillar_cuts(
        np.arange(-4.6, 4.5, 1.35), 0.12, hw, 0, 4
    )
    windshield = shell ^ box(hl - 0.3, hl + 0.1, -hw + 0.1, hw - 0.1, 1.0, 2.65)
    doors = [shell ^ box(x0, x0 + 1.2, -2.0, -0.5, 0.4, 2.75) for x0 in (3.6, -0.6)]
    rear = shell ^ box(-hl - 0.1, -hl + 0.2, -hw + 0.25, hw - 0.25, 1.9, 2.65)
    m.add("glass", union([band, windshield, rear, *doors]))
    m.add("display", shell ^ box(hl - 0.2, hl + 0.1, -0.9, 0.9, 2.72, 2.95))
    m.add("roof", rbox(-2.5, 1.0, -0.9, 0.9, 2.95, 3.2, 0.05))
    m.add(
        "trim",
        box(hl - 0.08, hl + 0.008, -hw + 0.05, hw - 0.05, 0.35, 0.55),
        box(-hl - 0.008, -hl + 0.08, -hw + 0.05, hw - 0.05, 0.35, 0.55),
    )
    for s in (1.0, -1.0):
        y0, y1 = sorted((s * 0.8, s * 1.1))
        m.add("headlight", box(hl - 0.03, hl + 0.01, y0, y1, 0.6, 0.78))
        m.add("taillight", box(-hl - 0.01, -hl + 0.03, y0, y1, 0.6, 1.0))
    add_car_wheels(m, axles, hw - 0.03, 0.5, 0.3)
    return m


def train_commuter() -> Model:
    m = Model()
    hl, hw, r = 10.0, 1.5, 0.25
    z0, z1 = 1.0, 3.55

    def car_body(grow: float) -> Manifold:
        rr = r + grow
        pts = []
        for s in (1.0, -1.0):  # both ends carry a cab
            pts += [
                (s * (hl - r), hw - r, z0 + r),
                (s * (hl - r), hw - 0.35, 2.0),
                (s * (hl - 0.9 - r), hw - r, z1 - r),
                (s * (hl - 2.0), hw - r, z0 + r),
            ]
        return blob(mirror_y(pts), rr, 12)

    m.add("paint_white", car_body(0.0))
    m.add("stripe", car_body(0.008) ^ box(-hl - 1, hl + 1, -2, 2, 1.45, 1.7))
    glass_band = (car_body(0.012) ^ box(-8.7, 8.7, -2, 2, 2.05, 2.85)) - pillar_cuts(
        np.arange(-8.0, 8.1, 1.6), 0.14, hw, 0, 4
    )
    cabs = car_body(0.012) ^ union([box(9.15, 11, -2, 2, 2.1, 3.05), box(-11, -9.15, -2, 2, 2.1, 3.05)])
    m.add("glass", union([glass_band, cabs]))
    m.add("door", car_body(0.016) ^ union([box(c - 0.65, c + 0.65, -2, 2, 1.05, 3.0) for c in (-5.0, 5.0)]))
    m.add(
        "bogie",
        box(-5.5, 5.5, -1.1, 1.1, 0.7, 1.05),
        *[box(c - 1.4, c + 1.4, -1.0, 1.0, 0.35, 0.85) for c in (-7.0, 7.0)],
    )
    for c in (-7.0, 7.0):
        for dx in (-0.9, 0.9):
            for s in (1.0, -1.0):
                m.add("wheel_steel", wheel_y(c + dx, s * 0.62, s * 0.78, 0.43, 0.43, seg=20))
    m.add(
        "trim",
        box(-3.0, -1.0, -0.6, 0.6, 3.45, 3.6),
        rod((-2.8, 0.0, 3.6), (-1.2, 0.0, 3.72), 0.03, seg=8),
        rod((-1.2, 0.0, 3.72), (-2.4, 0.0, 3.74), 0.025, seg=8),
        rod((-1.2, -0.8, 3.77), (-1.2, 0.8, 3.77), 0.03, seg=8),
    )
    for s in (1.0, -1.0):
        y0, y1 = sorted((s * 0.75, s * 1.05))
        m.add("headlight", box(hl - 0.05, hl + 0.006, y0, y1, 1.3, 1.45))
        m.add("taillight", box(-hl - 0.006, -hl + 0.05, y0, y1, 1.3, 1.45))
    return m


def motorcycle_street() -> Model:
    m = Model()
    wx, wr = 0.74, 0.32
    for x in (-wx, wx):
        m.add("tyre", ring_y((x, 0.0, wr), 0.255, 0.065, 32, 8))
        m.add(
            "rim",
            rod((x, -0.015, wr), (x, 0.015, wr), 0.2, seg=20),
            rod((x, -0.07, wr), (x, 0.07, wr), 0.05, seg=10),
        )
    m.add("engine", rbox(-0.25, 0.2, -0.16, 0.16, 0.28, 0.62, 0.04, 4))
    for s in (1.0, -1.0):
        m.add("metal", rod((wx, s * 0.09, wr), (0.54, s * 0.09, 1.0), 0.025, seg=8))
        m.add("metal", rod((-0.2, s * 0.1, 0.42), (-wx, s * 0.1, wr), 0.025, seg=8))
    m.add(
        "metal",
        rod((0.52, 0.0, 0.98), (-0.05, 0.0, 0.72), 0.03, seg=8),
        rod((0.5, 0.0, 0.95), (0.15, 0.0, 0.35), 0.03, seg=8),
        rod((-0.1, -0.2, 0.3), (-0.88, -0.2, 0.46), 0.05, seg=12),
        rod((0.48, -0.4, 1.12), (0.48, 0.4, 1.12), 0.014, seg=8),
        rod((0.53, 0.0, 1.0), (0.48, 0.0, 1.12), 0.025, seg=8),
    )
    m.add(
        "paint_red",
        blob(mirror_y([(0.05, 0.09, 0.8), (0.4, 0.07, 0.85), (0.05, 0.09, 0.92), (0.35, 0.05, 0.98)]), 0.1),
        blob(mirror_y([(-0.9, 0.06, 0.8), (-0.5, 0.1, 0.76), (-0.45, 0.08, 0.64)]), 0.05),
        blob(mirror_y([(0.58, 0.06, 0.67), (0.95, 0.06, 0.6)]), 0.03),
    )
    m.add(
        "seat",
        blob(mirror_y([(-0.6, 0.09, 0.86), (-0.02, 0.11, 0.89)]), 0.05),
        *[rod((0.48, s * 0.3, 1.12), (0.48, s * 0.4, 1.12), 0.02, seg=8) for s in (1.0, -1.0)],
    )
    m.add("headlight", ball((0.66, 0.0, 1.0), 0.09, 12))
    m.add("taillight", box(-0.96, -0.92, -0.06, 0.06, 0.78, 0.83))
    m.add("glass", blob(mirror_y([(0.64, 0.17, 1.08), (0.52, 0.14, 1.395)]), 0.005, 4))
    return m


def van_panel() -> Model:
    """A van: the car builder at the KITTI Van mean size, a tall boxy body with a short hood."""
    return _car(
        5.07,
        1.9,
        2.21,
        "paint_white",
        0.34,
        3.2,
        0.25,
        1.12,
        1.05,
        (-2.5, 1.55),
        (-2.5, 1.15),
        (0.95, 0.92),
        roof_rails=False,
    )


def tram_low_floor() -> Model:
    """A low-floor tram section at the KITTI Tram mean size: one long rail car with a cab at
    each end, a floor 0.35 m above the rail and a pantograph on the roof."""
    m = Model()
    hl, hw, r = 8.085, 1.265, 0.2
    z0, z1 = 0.35, 3.2

    def body(grow: float) -> Manifold:
        rr = r + grow
        pts = []
        for s in (1.0, -1.0):
            pts += [
                (s * (hl - r), hw - r, z0 + r),
                (s * (hl - 0.15 - r), hw - r, z1 - r),
                (s * (hl - 1.5), hw - r, z0 + r),
            ]
        return blob(mirror_y(pts), rr, 12)

    m.add("paint_white", body(0.0))
    m.add("stripe", body(0.008) ^ box(-hl - 1, hl + 1, -2, 2, 0.6, 0.85))
    band = (body(0.012) ^ box(-7.0, 7.0, -2, 2, 1.15, 2.6)) - pillar_cuts(np.arange(-6.3, 6.4, 1.4), 0.14, hw, 0, 4)
    cabs = body(0.012) ^ union([box(7.4, 9, -2, 2, 1.1, 2.75), box(-9, -7.4, -2, 2, 1.1, 2.75)])
    m.add("glass", union([band, cabs]))
    m.add("door", body(0.016) ^ union([box(c - 0.65, c + 0.65, -2, 2, 0.4, 2.7) for c in (-4.2, 0.0, 4.2)]))
    m.add("bogie", *[box(c - 1.0, c + 1.0, -0.95, 0.95, 0.12, 0.38) for c in (-5.6, 5.6)])
    for c in (-5.6, 5.6):
        for dx in (-0.6, 0.6):
            for sgn in (1.0, -1.0):
                m.add("wheel_steel", wheel_y(c + dx, sgn * 0.62, sgn * 0.76, 0.3, 0.3, seg=20))
    m.add(
        "trim",
        box(-1.2, 1.2, -0.7, 0.7, 3.15, 3.3),
        rod((-0.9, 0.0, 3.3), (0.4, 0.0, 3.47), 0.03, seg=8),
        rod((0.4, 0.0, 3.47), (-0.5, 0.0, 3.49), 0.025, seg=8),
        rod((0.4, -0.75, 3.5), (0.4, 0.75, 3.5), 0.03, seg=8),
    )
    for sgn in (1.0, -1.0):
        y0, y1 = sorted((sgn * 0.7, sgn * 1.0))
        m.add("headlight", box(hl - 0.05, hl + 0.006, y0, y1, 0.7, 0.85))
        m.add("taillight", box(-hl - 0.006, -hl + 0.05, y0, y1, 0.7, 0.85))
    return m


def trailer_box() -> Model:
    """A semi-trailer at the nuScenes trailer mean size: a box on three rear axles, landing
    legs and a king pin at the front."""
    m = Model()
    hl, hw = 6.005, 1.435
    axles = (-3.2, -4.3, -5.4)
    cargo = rbox(-hl, hl, -hw, hw, 1.25, 3.82, 0.04, 4)
    ribs = [box(x, x + 0.06, -hw - 0.004, hw + 0.004, 1.3, 3.77) for x in np.arange(-5.4, 5.6, 1.0)]
    m.add("paint_white", union([cargo, *ribs]))
    m.add(
        "chassis",
        box(-hl + 0.2, hl - 0.3, -0.55, 0.55, 0.95, 1.25),
        box(-5.9, -2.7, -1.1, 1.1, 0.75, 0.95),
        box(-hl, -hl + 0.15, -1.2, 1.2, 0.55, 0.75),
        *[box(3.6, 3.75, sgn * 1.0 - 0.08, sgn * 1.0 + 0.08, 0.0, 1.0) for sgn in (1.0, -1.0)],
        rod((hl - 0.9, 0.0, 0.95), (hl - 0.9, 0.0, 0.75), 0.05, seg=10),
    )
    for sgn in (1.0, -1.0):
        y0, y1 = sorted((sgn * 0.9, sgn * 1.2))
        m.add("taillight", box(-hl - 0.004, -hl + 0.03, y0, y1, 0.6, 0.72))
    add_car_wheels(m, axles, hw - 0.02, 0.5, 0.55)
    return m


def construction_loader() -> Model:
    """A construction vehicle at the nuScenes construction_vehicle mean size: a wheel loader,
    engine box and cab on four large wheels, a boom and a bucket at the front."""
    m = Model()
    hw = 1.365
    axles = (1.45, -1.55)
    m.add(
        "paint_yellow",
        rbox(-3.19, -0.55, -1.05, 1.05, 0.7, 2.15, 0.08, 4),
        rbox(-0.7, 1.9, -0.9, 0.9, 0.55, 1.3, 0.05, 4),
        rbox(-0.6, 0.85, -0.85, 0.85, 1.3, 3.13, 0.06, 4),
        *[
            rod((0.6, sgn * 0.75, 1.55), (2.55, sgn * 0.75, 1.05), 0.12, seg=10)
            for sgn in (1.0, -1.0)
        ],
    )
    cab_glass = rbox(-0.612, 0.862, -0.862, 0.862, 1.288, 3.142, 0.06, 4) ^ box(-1, 1, -2, 2, 1.9, 2.95)
    m.add("glass", cab_glass - pillar_cuts([0.12], 0.12, 0.9, 0, 4))
    m.add(
        "metal",
        prism_xz([(2.45, 0.12), (3.19, 0.12), (3.19, 0.55), (2.8, 1.15), (2.45, 1.15)], -hw + 0.05, hw - 0.05)
        - box(2.6, 3.3, -hw + 0.15, hw - 0.15, 0.25, 1.3),
    )
    m.add("chassis", box(-2.9, 1.7, -0.6, 0.6, 0.45, 0.75))
    m.add("headlight", *[box(0.83, 0.87, sgn * 0.6 - 0.1, sgn * 0.6 + 0.1, 2.9, 3.02) for sgn in (1.0, -1.0)])
    m.add("taillight", *[box(-3.2, -3.17, sgn * 0.8 - 0.1, sgn * 0.8 + 0.1, 1.8, 1.95) for sgn in (1.0, -1.0)])
    add_car_wheels(m, axles, hw, 0.72, 0.5)
    return m


def bicycle_city() -> Model:
    m = Model()
    add_bicycle(m)
    return m


WALKING = Pose(
    head=(0.02, 0.0, 1.64),
    neck=(0.0, 0.0, 1.47),
    shoulders=((0.0, 0.15, 1.4), (0.0, -0.15, 1.4)),
    waist=((0.0, 0.12, 1.04), (0.0, -0.12, 1.04)),
    hips=((0.0, 0.095, 0.9), (0.0, -0.095, 0.9)),
    knees=((-0.09, 0.1, 0.5), (0.13, -0.1, 0.5)),
    ankles=((-0.2, 0.1, 0.12), (0.13, -0.1, 0.09)),
    toes=((-0.04, 0.1, 0.045), (0.27, -0.1, 0.045)),
    elbows=((0.1, 0.23, 1.16), (-0.1, -0.23, 1.17)),
    wrists=((0.19, 0.245, 0.97), (-0.16, -0.245, 0.98)),
    hands=((0.22, 0.25, 0.92), (-0.18, -0.25, 0.93)),
)

STANDING = Pose(
    head=(0.0, 0.0, 1.64),
    neck=(0.0, 0.0, 1.47),
    shoulders=((0.0, 0.15, 1.4), (0.0, -0.15, 1.4)),
    waist=((0.0, 0.12, 1.04), (0.0, -0.12, 1.04)),
    hips=((0.0, 0.095, 0.9), (0.0, -0.095, 0.9)),
    knees=((0.015, 0.1, 0.5), (0.015, -0.1, 0.5)),
    ankles=((0.0, 0.11, 0.09), (0.0, -0.11, 0.09)),
    toes=((0.15, 0.12, 0.045), (0.15, -0.12, 0.045)),
    elbows=((-0.01, 0.22, 1.13), (-0.01, -0.22, 1.13)),
    wrists=((0.02, 0.235, 0.88), (0.02, -0.235, 0.88)),
    hands=((0.03, 0.24, 0.82), (0.03, -0.24, 0.82)),
)


def person_walking() -> Model:
    m = Model()
    add_person(m, WALKING)
    return m


def person_standing() -> Model:
    m = Model()
    add_person(m, STANDING, top="jacket")
    return m


def rider_bicycle() -> Model:
    m = Model()
    c = add_bicycle(m)
    sx, _, sz = c["saddle"]
    gl, gr = c["grip_left"], c["grip_right"]
    pf, pr = c["pedal_front"], c["pedal_rear"]
    pose = Pose(
        head=(0.1, 0.0, 1.62),
        neck=(0.04, 0.0, 1.46),
        shoulders=((-0.01, 0.15, 1.42), (-0.01, -0.15, 1.42)),
        waist=((sx + 0.02, 0.12, sz + 0.1), (sx + 0.02, -0.12, sz + 0.1)),
        hips=((sx + 0.03, 0.1, sz), (sx + 0.03, -0.1, sz)),
        knees=((pr[0] + 0.2, 0.13, 0.66), (pf[0] + 0.02, -0.13, 0.74)),
        ankles=((pr[0] + 0.0, 0.12, pr[2] + 0.06), (pf[0] - 0.02, -0.12, pf[2] + 0.06)),
        toes=((pr[0] + 0.12, 0.12, pr[2] + 0.02), (pf[0] + 0.1, -0.12, pf[2] + 0.02)),
        elbows=((0.15, 0.22, 1.24), (0.15, -0.22, 1.24)),
        wrists=((gl[0] - 0.03, gl[1], gl[2] + 0.03), (gr[0] - 0.03, gr[1], gr[2] + 0.03)),
        hands=(gl, gr),
    )
    add_person(m, pose, top="jacket", headwear="helmet")
    return m


def misc_crates() -> Model:
    m = Model()
    wood = [box(-1.0, 1.0, y - 0.07, y + 0.07, 0.0, 0.025) for y in (-0.65, 0.0, 0.65)]
    wood += [
        box(x - 0.06, x + 0.06, y - 0.06, y + 0.06, 0.025, 0.115)
        for x in (-0.94, 0.0, 0.94)
        for y in (-0.65, 0.0, 0.65)
    ]
    wood += [box(-1.0, 1.0, y - 0.07, y + 0.07, 0.115, 0.14) for y in np.linspace(-0.68, 0.68, 7)]
    m.add("wood_light", union(wood))
    crates = [
        (-0.98, -0.02, -0.73, -0.02, 0.14, 0.74),
        (0.02, 0.98, -0.73, -0.02, 0.14, 0.74),
        (-0.98, -0.02, 0.02, 0.73, 0.14, 0.74),
        (0.02, 0.98, 0.02, 0.73, 0.14, 0.74),
        (-0.95, -0.05, -0.7, 0.0, 0.74, 1.24),
        (0.0, 0.9, -0.3, 0.7, 0.74, 1.3),
        (-0.6, 0.0, -0.5, 0.1, 1.24, 1.5),
    ]
    m.add("cardboard", *[rbox(*c, 0.012, 4) for c in crates])
    tape = []
    for x0, x1, y0, y1, _, z1 in crates:
        yc = 0.5 * (y0 + y1)
        tape.append(box(x0 + 0.004, x1 - 0.004, yc - 0.04, yc + 0.04, z1 - 0.004, z1 + 0.002))
    m.add("tape", *tape)
    return m


def tree_deciduous() -> Model:
    m = Model()
    m.add(
        "bark",
        rod((0, 0, 0), (0, 0, 3.6), 0.2, 0.12, 12),
        rod((0, 0, 0), (0, 0, 0.3), 0.32, 0.2, 12),
        rod((0, 0, 2.4), (0.8, 0.45, 3.8), 0.09, 0.05, 8),
        rod((0, 0, 2.7), (-0.75, -0.5, 4.0), 0.08, 0.05, 8),
    )
    crown = [
        ((0.0, 0.0, 4.9), 1.75, (1.0, 1.0, 0.95)),
        ((0.85, 0.55, 4.3), 1.15, (1.0, 0.95, 0.9)),
        ((-0.9, 0.5, 4.5), 1.1, (1.0, 1.0, 0.9)),
        ((0.3, -0.85, 4.35), 1.15, (0.95, 1.0, 0.9)),
        ((-0.6, -0.55, 5.5), 1.2, (1.0, 1.0, 1.0)),
        ((0.45, 0.8, 5.55), 1.2, (1.0, 1.0, 1.0)),
    ]
    m.add("leaves", *[ball(c, r, 12, s) for c, r, s in crown])
    return m


def tree_conifer() -> Model:
    m = Model()
    m.add("bark", rod((0, 0, 0), (0, 0, 2.0), 0.18, 0.1, 10))
    tiers = [(0.8, 3.2, 1.5), (2.6, 2.9, 1.2), (4.3, 2.6, 0.9), (5.8, 2.2, 0.6)]
    m.add("needles", *[Manifold.cylinder(h, r, 0.0, 16).translate((0, 0, z)) for z, h, r in tiers])
    return m


def _span(a: float, b: float) -> tuple[float, float]:
    """(min, max) of two coordinates."""
    return (a, b) if a <= b else (b, a)


def _windows_x(
    m: Model,
    face_x: float,
    ys: Sequence[float],
    z0: float,
    z1: float,
    width: float,
    sign: float,
    depth: float = 0.15,
) -> list[Manifold]:
    """Window recess cutters on a facade normal to X; adds glass panes and sills to ``m``."""
    cuts = []
    for y in ys:
        y0, y1 = y - width / 2, y + width / 2
        cuts.append(box(*_span(face_x - sign * depth, face_x + sign * 0.05), y0, y1, z0, z1))
        m.add("window", box(*_span(face_x - sign * (depth + 0.02), face_x - sign * 0.08), y0, y1, z0, z1))
        sill = _span(face_x - sign * 0.02, face_x + sign * 0.06)
        m.add("concrete", box(*sill, y0 - 0.08, y1 + 0.08, z0 - 0.06, z0))
    return cuts


def _windows_y(
    m: Model,
    face_y: float,
    xs: Sequence[float],
    z0: float,
    z1: float,
    width: float,
    sign: float,
    depth: float = 0.15,
) -> list[Manifold]:
    """Window recess cutters on a facade normal to Y; adds glass panes and sills to ``m``."""
    cuts = []
    for x in xs:
        x0, x1 = x - width / 2, x + width / 2
        cuts.append(box(x0, x1, *_span(face_y - sign * depth, face_y + sign * 0.05), z0, z1))
        m.add("window", box(x0, x1, *_span(face_y - sign * (depth + 0.02), face_y - sign * 0.08), z0, z1))
        sill = _span(face_y - sign * 0.02, face_y + sign * 0.06)
        m.add("concrete", box(x0 - 0.08, x1 + 0.08, *sill, z0 - 0.06, z0))
    return cuts


def building_residential() -> Model:
    m = Model()
    hx, hy, storey, storeys = 5.8, 4.8, 3.0, 3
    cuts: list[Manifold] = []
    for k in range(storeys):
        z0 = k * storey + 0.9
        front_ys = (-2.8, 2.8) if k == 0 else (-3.4, -1.2, 1.2, 3.4)
        cuts += _windows_x(m, hx, front_ys, z0, z0 + 1.4, 1.2, 1.0)
        cuts += _windows_x(m, -hx, (-3.4, -1.2, 1.2, 3.4), z0, z0 + 1.4, 1.2, -1.0)
        for s in (1.0, -1.0):
            cuts += _windows_y(m, s * hy, (-3.9, -1.3, 1.3, 3.9), z0, z0 + 1.4, 1.2, s)
    cuts.append(box(hx - 0.25, hx + 0.1, -0.65, 0.65, 0.0, 2.3))
    walls = box(-hx, hx, -hy, hy, 0.0, storeys * storey) - union(cuts)
    m.add("wall", walls)
    m.add("door", box(hx - 0.2, hx - 0.12, -0.6, 0.6, 0.0, 2.25))
    bands = [
        box(-hx - 0.05, hx + 0.05, -hy - 0.05, hy + 0.05, k * storey - 0.08, k * storey + 0.08)
        for k in (1, 2)
    ]
    bands.append(box(-hx - 0.03, hx + 0.03, -hy - 0.03, hy + 0.03, 0.0, 0.35))
    m.add("concrete", union(bands))
    eave = storeys * storey
    m.add("roof_tiles", _gable_roof(6.0, 5.0, eave, 12.0))
    m.add("wall", box(-0.5, 0.5, 2.0, 2.7, 9.5, 11.8))  # chimney
    return m


def _gable_roof(half_x: float, half_y: float, z_eave: float, z_ridge: float) -> Manifold:
    """Gable roof with the ridge along X: a triangular prism, YZ profile extruded along X."""
    profile = section([(-half_y, z_eave), (half_y, z_eave), (0.0, z_ridge)])
    # extrude (y, z) along +X: (a, b, e) -> (e, a, b), a proper rotation (cyclic permutation)
    m = np.array([[0.0, 0.0, 1.0, -half_x], [1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])
    return Manifold.extrude(profile, 2 * half_x).transform(m)


def building_office() -> Model:
    m = Model()
    hx, hy = 8.0, 6.0
    levels = [0.0, 4.2] + [4.2 + 3.6 * k for k in range(1, 6)]
    top = levels[-1]
    m.add("curtain_wall", box(-hx + 0.1, hx - 0.1, -hy + 0.1, hy - 0.1, 0.0, top))
    slabs = [box(-hx, hx, -hy, hy, z - 0.2, z + 0.15) for z in levels[1:]]
    slabs.append(box(-hx, hx, -hy, hy, top, top + 0.6))
    slabs.append(box(-2.5, 2.0, -2.0, 2.0, top + 0.6, 24.0))
    slabs.append(box(hx - 0.4, hx + 0.0, -2.5, 2.5, 3.1, 3.5))
    m.add("concrete", union(slabs))
    mullions = []
    for x in np.arange(-hx + 1.0, hx - 0.5, 2.0):
        for s in (1.0, -1.0):
            y0, y1 = sorted((s * (hy - 0.12), s * (hy + 0.0)))
            mullions.append(box(x - 0.05, x + 0.05, y0, y1, 0.0, top))
    for y in np.arange(-hy + 1.0, hy - 0.5, 2.0):
        for s in (1.0, -1.0):
            x0, x1 = sorted((s * (hx - 0.12), s * (hx + 0.0)))
            mullions.append(box(x0, x1, y - 0.05, y + 0.05, 0.0, top))
    m.add("mullion", *mullions)
    m.add("door", box(hx - 0.1, hx + 0.0, -1.5, 1.5, 0.0, 2.8))
    return m


def pole_plain() -> Model:
    m = Model()
    m.add("concrete", Manifold.cylinder(0.1, 0.15, 0.14, 20))
    m.add(
        "pole_metal",
        rod((0, 0, 0.1), (0, 0, 0.7), 0.11, 0.09, 16),
        rod((0, 0, 0.7), (0, 0, 5.95), 0.075, 0.055, 16),
        rod((0, 0, 5.95), (0, 0, 6.0), 0.065, 0.04, 16),
    )
    return m


def pole_street_lamp() -> Model:
    m = Model()
    m.add("concrete", Manifold.cylinder(0.1, 0.15, 0.14, 20))
    m.add(
        "pole_metal",
        rod((0, 0, 0.1), (0, 0, 0.7), 0.11, 0.09, 16),
        rod((0, 0, 0.7), (0, 0, 7.6), 0.08, 0.055, 16),
        rod((0, 0, 7.3), (0.6, 0, 7.82), 0.045, 0.04, 10),
        rod((0.55, 0, 7.8), (1.35, 0, 7.88), 0.04, seg=10),
        rbox(1.2, 1.9, -0.14, 0.14, 7.76, 7.96, 0.04, 8),
    )
    m.add("lamp", box(1.3, 1.8, -0.1, 0.1, 7.73, 7.77))
    return m


def traffic_light_three() -> Model:
    m = Model()
    m.add("concrete", box(-0.25, 0.25, -0.25, 0.25, 0.0, 0.08))
    m.add("pole_metal", rod((0, 0, 0.08), (0, 0, 3.45), 0.065, seg=16))
    housing = [rbox(-0.13, 0.13, -0.17, 0.17, 3.45, 4.4, 0.03), box(-0.16, -0.13, -0.25, 0.25, 3.38, 4.5)]
    lamps = {"lamp_red": 4.22, "lamp_amber": 3.925, "lamp_green": 3.63}
    for name, z in lamps.items():
        hood = rod((0.12, 0, z), (0.25, 0, z), 0.125, seg=20) - rod((0.11, 0, z), (0.26, 0, z), 0.11, seg=20)
        housing.append(hood - box(0.0, 0.3, -0.3, 0.3, z - 0.2, z + 0.01))
        m.add(name, ball((0.09, 0.0, z), 0.1, 16) ^ box(0.12, 0.3, -0.3, 0.3, z - 0.2, z + 0.2))
    m.add("housing", union(housing))
    return m


def _sign(face: str) -> Model:
    """A sign post; the plate is modelled in the XZ plane and turned so that its face points +X."""
    m = Model()
    m.add(
        "pole_metal", Manifold.cylinder(0.02, 0.05, 0.045, 16), rod((0, 0, 0.02), (0, 0, 2.6), 0.03, seg=12)
    )
    y_back, y_face, y_front = 0.03, 0.045, 0.05
    if face == "round":
        zc = 2.45
        disc = lambda r, y0, y1: rod((0, y0, zc), (0, y1, zc), r, seg=32)
        m.add("sign_back", disc(0.35, y_back, y_face))
        m.add("sign_red", disc(0.35, y_face, y_front) - disc(0.27, y_face - 0.01, y_front + 0.01))
        m.add("sign_white", disc(0.27, y_face, y_front))
    elif face == "triangle":
        zb = 2.15
        outer = section([(-0.375, zb), (0.375, zb), (0.0, zb + 0.65)])
        inner = outer.offset(-0.07, JoinType.Miter)
        m.add("sign_back", prism_xz(outer, y_back, y_face))
        m.add("sign_red", prism_xz(outer - inner, y_face, y_front))
        m.add("sign_white", prism_xz(inner, y_face, y_front))
    else:  # information panel
        outer = section([(-0.35, 1.95), (0.35, 1.95), (0.35, 2.75), (-0.35, 2.75)])
        inner = outer.offset(-0.03, JoinType.Miter)
        m.add("sign_back", prism_xz(outer, y_back, y_face))
        m.add("sign_white", prism_xz(outer - inner, y_face, y_front))
        m.add("sign_blue", prism_xz(inner, y_face, y_front))
    return m.rotated_z(-90.0)


def sign_round() -> Model:
    return _sign("round")


def sign_triangle() -> Model:
    return _sign("triangle")


def sign_rectangle() -> Model:
    return _sign("rectangle")


def fence_wooden() -> Model:
    m = Model()
    xs = np.linspace(-1.45, 1.45, 4)
    m.add("concrete", *[box(x - 0.1, x + 0.1, -0.1, 0.1, 0.0, 0.08) for x in xs])
    m.add("wood", *[box(x - 0.05, x + 0.05, -0.05, 0.05, 0.0, 1.6) for x in xs])
    m.add("wood_light", *[box(-1.5, 1.5, 0.05, 0.09, z - 0.06, z + 0.06) for z in (0.35, 0.85, 1.35)])
    return m


def fence_railing() -> Model:
    m = Model()
    xs = np.linspace(-1.45, 1.45, 3)
    m.add(
        "pole_metal",
        *[box(x - 0.03, x + 0.03, -0.03, 0.03, 0.0, 1.1) for x in xs],
        box(-1.5, 1.5, -0.025, 0.025, 1.06, 1.12),
        box(-1.5, 1.5, -0.02, 0.02, 0.12, 0.16),
        *[rod((x, 0, 0.14), (x, 0, 1.08), 0.009, seg=6) for x in np.arange(-1.35, 1.36, 0.12)],
    )
    return m


Builder = Callable[[], Model]

#: class -> variants (name, builder), default first. Only the default is fitted to size_m.
ASSETS: dict[str, tuple[tuple[str, Builder], ...]] = {
    "car": (("hatchback", car_hatchback), ("sedan", car_sedan), ("suv", car_suv)),
    "truck": (("box_truck", truck_box),),
    "bus": (("city_bus", bus_city),),
    "train": (("commuter", train_commuter),),
    "motorcycle": (("street", motorcycle_street),),
    "bicycle": (("city", bicycle_city),),
    "person": (("walking", person_walking), ("standing", person_standing)),
    "rider": (("bicycle", rider_bicycle),),
    "misc": (("crates", misc_crates),),
    "van": (("panel", van_panel),),
    "tram": (("low_floor", tram_low_floor),),
    "trailer": (("box", trailer_box),),
    "construction_vehicle": (("loader", construction_loader),),
    "tree": (("deciduous", tree_deciduous), ("conifer", tree_conifer)),
    "building": (("residential", building_residential), ("office", building_office)),
    "pole": (("plain", pole_plain), ("street_lamp", pole_street_lamp)),
    "traffic_light": (("three_lamp", traffic_light_three),),
    "traffic_sign": (("round", sign_round), ("triangle", sign_triangle), ("rectangle", sign_rectangle)),
    "fence": (("wooden", fence_wooden), ("railing", fence_railing)),
}


# --------------------------------------------------------------------------------------------
# Meshing: solids -> rounded, shaded triangle meshes in the asset frame
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class MeshData:
    """One Mesh prim: ``points`` (N, 3) float64 m, ``faces`` (M, 3) int32, ``normals`` (3M, 3) float32."""

    name: str
    material: Material
    points: np.ndarray
    faces: np.ndarray
    normals: np.ndarray


@dataclass(frozen=True)
class VariantData:
    """The meshes of one variant and its measured bounding-box size (l, w, h) in metres."""

    meshes: tuple[MeshData, ...]
    size: Vec3


def mesh_variant(model: Model, target: Vec3 | None, where: str) -> VariantData:
    """Union each material's solids, move the footprint centre to the origin, fit ``target``, shade."""
    solids = {name: union(parts) for name, parts in model.parts.items()}
    boxes = np.array([s.bounding_box() for s in solids.values() if not s.is_empty()])
    lo, hi = boxes[:, :3].min(axis=0), boxes[:, 3:].max(axis=0)
    built = hi - lo
    scale = np.ones(3)
    if target is not None:
        scale = np.asarray(target, float) / built
        if np.any(np.abs(scale - 1.0) > MAX_FIT_CORRECTION):
            raise ValueError(
                f"{where}: built size {np.round(built, 3).tolist()} is more than "
                f"{MAX_FIT_CORRECTION:.0%} off size_m {list(target)}; fix the builder"
            )
    origin = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]])
    meshes = []
    for name, solid in solids.items():
        if solid.is_empty():
            raise ValueError(f"{where}/{name}: empty solid")
        mesh = solid.to_mesh()
        points = np.round((np.asarray(mesh.vert_properties)[:, :3] - origin) * scale, POINT_DECIMALS) + 0.0
        faces = np.asarray(mesh.tri_verts, dtype=np.int64)
        # rounding can collapse boolean slivers: weld the points and drop the degenerate faces
        tm = trimesh.Trimesh(points, faces, process=True, validate=True)
        if not (tm.is_watertight and tm.is_winding_consistent) or np.any(tm.area_faces <= 1e-12):
            raise ValueError(f"{where}/{name}: mesh is not a clean closed manifold after rounding")
        points, faces = np.asarray(tm.vertices, dtype=np.float64), np.asarray(tm.faces, dtype=np.int64)
        meshes.append(
            MeshData(
                name, model.material(name), points, faces.astype(np.int32), crease_normals(points, faces)
            )
        )
    all_points = np.concatenate([m.points for m in meshes])
    size = all_points.max(axis=0) - all_points.min(axis=0)
    return VariantData(tuple(meshes), (float(size[0]), float(size[1]), float(size[2])))


# --------------------------------------------------------------------------------------------
# USD authoring
# --------------------------------------------------------------------------------------------


def _define_material(stage: Usd.Stage, path: str, material: Material) -> UsdShade.Material:
    mat = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/PreviewSurface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*material.color))
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(material.roughness)
    shader.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(material.metallic)
    mat.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return mat


def write_asset(out_dir: Path, class_name: str, variants: dict[str, VariantData], default: str) -> list[Path]:
    """Write ``<class>.usda`` and its ``<class>.geom.usdc`` sublayer into ``out_dir``."""
    usda_path = out_dir / f"{class_name}.usda"
    geom_path = out_dir / f"{class_name}.geom.usdc"
    geom_layer = Sdf.Layer.CreateNew(str(geom_path))
    root_layer = Sdf.Layer.CreateNew(str(usda_path))
    root_layer.customLayerData = {"creator": CREATOR}
    root_layer.documentation = (
        f"usdworld class asset '{class_name}': generated by tools/make_assets.py, do not edit. "
        f"Mesh arrays live in the sublayer {geom_path.name}."
    )
    geom_layer.documentation = (
        f"Mesh arrays of {usda_path.name} (generated by tools/make_assets.py, do not edit)."
    )
    root_layer.subLayerPaths.append(f"./{geom_path.name}")
    stage = Usd.Stage.Open(root_layer)
    stage.SetEditTarget(Usd.EditTarget(root_layer))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)

    root_path = f"/{class_name}"
    prim = define_asset_root(stage, class_name)
    # nested under "usdworld", so prim.GetCustomDataByKey("usdworld:sizeByVariant") reads it
    prim.SetCustomDataByKey("usdworld:defaultVariant", default)
    prim.SetCustomDataByKey(
        "usdworld:sizeByVariant", {v: Gf.Vec3d(*(round(c, 4) for c in d.size)) for v, d in variants.items()}
    )

    vset = prim.GetVariantSets().AddVariantSet(VARIANT_SET)
    for variant, data in variants.items():
        vset.AddVariant(variant)
        vset.SetVariantSelection(variant)
        with vset.GetVariantEditContext():
            all_points = np.concatenate([m.points for m in data.meshes])
            UsdGeom.ModelAPI(prim).SetExtentsHint(extent(all_points))
            for md in data.meshes:
                mat = _define_material(stage, f"{root_path}/Looks/{md.name}", md.material)
                mesh = UsdGeom.Mesh.Define(stage, f"{root_path}/Geom/{md.name}")
                mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
                mesh.CreateExtentAttr(extent(md.points))
                mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set(
                    Vt.Vec3fArray([Gf.Vec3f(*md.material.color)])
                )
                UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(mat)
                UsdSemantics.LabelsAPI.Apply(mesh.GetPrim(), TAXONOMY).CreateLabelsAttr([class_name])
        stage.SetEditTarget(vset.GetVariantEditTarget(geom_layer))
        for md in data.meshes:
            mesh = UsdGeom.Mesh(stage.GetPrimAtPath(f"{root_path}/Geom/{md.name}"))
            mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(md.points.astype(np.float32)))
            mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(md.faces), 3, dtype=np.int32)))
            mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(md.faces.reshape(-1)))
            mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(md.normals))
            mesh.SetNormalsInterpolation(UsdGeom.Tokens.faceVarying)
        stage.SetEditTarget(Usd.EditTarget(root_layer))
    vset.SetVariantSelection(default)
    root_layer.Save()
    geom_layer.Save()
    return [usda_path, geom_path]


# --------------------------------------------------------------------------------------------
# Driver
# --------------------------------------------------------------------------------------------


def load_priors(path: Path = PRIORS_PATH) -> dict[str, Vec3]:
    """class -> size_m from the class priors table."""
    table = json.loads(path.read_text(encoding="utf-8"))
    return {name: tuple(map(float, row["size_m"])) for name, row in table.items() if not name.startswith("_")}  # type: ignore[misc]


def build_class(class_name: str, size_m: Vec3) -> dict[str, VariantData]:
    """Mesh every variant of one class; the first (default) is fitted to ``size_m``."""
    if class_name not in ASSETS:
        raise KeyError(
            f"class_priors.json lists '{class_name}' but tools/make_assets.py has no builder for it"
        )
    out = {}
    for i, (variant, builder) in enumerate(ASSETS[class_name]):
        out[variant] = mesh_variant(builder(), size_m if i == 0 else None, f"{class_name}/{variant}")
    return out


def generate(out_dir: Path, classes: Sequence[str] | None = None) -> list[Path]:
    """Build the library into ``out_dir`` (files are written to a scratch folder, then moved in)."""
    priors = load_priors()
    names = list(priors) if not classes else list(classes)
    unknown = [n for n in names if n not in priors]
    if unknown:
        raise SystemExit(f"error: unknown class(es) {unknown}; known: {', '.join(priors)}")
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    with tempfile.TemporaryDirectory(prefix=".make_assets-", dir=out_dir) as scratch:
        for name in names:
            variants = build_class(name, priors[name])
            files = write_asset(Path(scratch), name, variants, ASSETS[name][0][0])
            usda = Path(scratch) / f"{name}.usda"
            record = validation_record(validate_asset(usda))
            files.append(write_card(usda, asset_card_text(usda, record)))
            for f in files:
                dest = out_dir / f.name
                os.replace(f, dest)
                written.append(dest)
    return written


def library_files(folder: Path) -> list[str]:
    """Generated-file names present in ``folder``."""
    return (
        sorted(p.name for p in folder.glob("*.usda"))
        + sorted(p.name for p in folder.glob("*.geom.usdc"))
        + sorted(p.name for p in folder.glob(f"*{CARD_SUFFIX}"))
    )


def check(out_dir: Path, classes: Sequence[str] | None = None) -> list[str]:
    """Files of ``out_dir`` that differ from a fresh generation (empty when up to date)."""
    with tempfile.TemporaryDirectory(prefix="make_assets-check-") as scratch:
        fresh = Path(scratch)
        generate(fresh, classes)
        problems = []
        for name in library_files(fresh):
            have = out_dir / name
            if not have.is_file():
                problems.append(f"missing: {name}")
            elif have.read_bytes() != (fresh / name).read_bytes():
                problems.append(f"differs: {name}")
        if not classes:
            problems += [
                f"not generated (stale?): {n}" for n in library_files(out_dir) if not (fresh / n).exists()
            ]
    return problems


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--out", type=Path, default=DEFAULT_OUT, help="library folder (default: asset_library/)"
    )
    parser.add_argument(
        "--check", action="store_true", help="exit 1 if the library differs from a fresh generation"
    )
    parser.add_argument("--only", nargs="+", metavar="CLASS", help="limit to these classes")
    args = parser.parse_args(argv)
    if args.check:
        problems = check(args.out, args.only)
        for p in problems:
            print(p)
        if problems:
            print(f"{args.out} is stale: run python tools/make_assets.py", file=sys.stderr)
            return 1
        print(f"{args.out}: up to date")
        return 0
    written = generate(args.out, args.only)
    total = sum(p.stat().st_size for p in written)
    print(f"wrote {len(written)} files ({total / 1024:.0f} KiB) to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
