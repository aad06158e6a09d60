"""Where a trunk's or post's base stands in its asset, and a street lamp placed by its mast.

The photo shows a street lamp's mast meeting the ground; the asset's origin is the middle
of its whole footprint, ~0.9 m from the mast towards the arm's end.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from layout_support import box_object

from usdworld.authoring.asset_library import library_dirs, load_mesh_arrays
from usdworld.authoring.asset_measures import (
    CONTACT_HEIGHT_M,
    asset_catalogue,
    measure_mesh,
    variant_measures,
)
from usdworld.geometry.camera import PinholeCamera
from usdworld.io.asset_catalogue import AssetCatalogue
from usdworld.io.class_table import load_class_table
from usdworld.layout.placement import place_objects
from usdworld.layout.yaw import RoadAxis
from usdworld.parameters.placement import PlacementParams

K = np.array([[800.0, 0.0, 512.0], [0.0, 800.0, 256.0], [0.0, 0.0, 1.0]])
CAM = PinholeCamera(1024, 512, K, 1.3)


def _box(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """(8, 3) corners and (12, 3) triangles of an axis-aligned box."""
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    faces = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    return corners.astype(np.float64), faces


def _lamp(dx: float = 0.0, dy: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """A lamp-like mesh: a 0.2 m mast at x = -0.9 and, 6 m up, an arm reaching x = +1, shifted by (dx, dy)."""
    mast_v, mast_f = _box((-1.0, -0.1, 0.0), (-0.8, 0.1, 6.0))
    arm_v, arm_f = _box((-0.8, -0.05, 5.8), (1.0, 0.05, 6.0))
    verts = np.vstack([mast_v, arm_v]) + np.array([dx, dy, 0.0])
    return verts, np.vstack([mast_f, arm_f + len(mast_v)])


def test_the_contact_offset_of_a_lamp_is_its_masts_centre_not_the_footprints():
    m = measure_mesh(*_lamp())
    assert m.contact_offset == pytest.approx((-0.9, 0.0), abs=1e-12)
    assert m.contact_half == pytest.approx((1.0, 0.1), abs=1e-12)  # about the origin: mast's far side


@settings(max_examples=25, deadline=None)
@given(st.floats(-3.0, 3.0), st.floats(-3.0, 3.0))
def test_shifting_a_mesh_shifts_its_contact_offset_by_as_much(dx: float, dy: float):
    m = measure_mesh(*_lamp(dx, dy))
    assert m.contact_offset == pytest.approx((-0.9 + dx, dy), abs=1e-9)


def test_the_built_in_street_lamps_contact_is_its_mast():
    mesh = load_mesh_arrays("pole", "street_lamp", None)
    low = mesh.vertices[mesh.vertices[:, 2] <= mesh.vertices[:, 2].min() + CONTACT_HEIGHT_M]
    mast = 0.5 * (low.min(axis=0) + low.max(axis=0))[:2]
    assert mast[0] < -0.8  # the arm reaches +X: the mast stands well behind the origin
    assert variant_measures("pole", "street_lamp").contact_offset == pytest.approx(tuple(mast), abs=1e-9)
    assert variant_measures("pole", "plain").contact_offset == pytest.approx((0.0, 0.0), abs=1e-9)


def test_a_placed_street_lamps_mast_stands_where_the_photo_shows_it():
    catalogue = asset_catalogue(["pole"], library_dirs(None))
    lamp_only = replace(
        catalogue["pole"],
        by_variant={"street_lamp": catalogue["pole"].by_variant["street_lamp"]},
        default_variant="street_lamp",
        **{
            f: {"street_lamp": getattr(catalogue["pole"], f)["street_lamp"]}
            for f in (
                "contact_half_by_variant",
                "top_half_by_variant",
                "contact_mean_reach_by_variant",
                "top_shape_by_variant",
                "contact_offset_by_variant",
            )
        },
    )
    # A 270 px lamp right of the road, its mast's base at row 300 (about 23.6 m ahead).
    lamp = box_object("pole", (700, 30, 706, 300), 1)
    placements, skipped = place_objects(
        [lamp],
        CAM,
        np.linalg.inv(CAM.px_from_ground()),
        RoadAxis(0.0, np.zeros(2), "camera_forward"),
        AssetCatalogue({"pole": lamp_only}),
        load_class_table(),
        PlacementParams(),
    )
    assert skipped == [] and len(placements) == 1
    p = placements[0]
    assert p.variant == "street_lamp"
    assert p.yaw == pytest.approx(np.pi / 2)  # right of the road: the arm (+X) reaches over it
    c, s = np.cos(p.yaw), np.sin(p.yaw)
    mesh = load_mesh_arrays("pole", "street_lamp", None)
    low = mesh.vertices[mesh.vertices[:, 2] <= mesh.vertices[:, 2].min() + CONTACT_HEIGHT_M]
    mast_asset = 0.5 * (low.min(axis=0) + low.max(axis=0))[:2] * p.scale
    mast = p.position_world[:2] + np.array([[c, -s], [s, c]]) @ mast_asset
    px, _ = CAM.project(np.array([[mast[0], mast[1], 0.0]]))
    assert px[0, 0] == pytest.approx(703.0, abs=0.05)  # on the viewing ray of its contact pixel
    # its centre just behind its front, by the mast's half width (0.15 m at unit scale)
    front = CAM.project(np.array([[mast[0] - 0.15 * p.scale, mast[1], 0.0]]))[0][0, 1]
    assert front == pytest.approx(299.5, abs=0.2)
