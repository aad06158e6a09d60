"""Edit rules see a street lamp by its mast: the trunk footprint stands where the mast does."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Usd

from usdworld.authoring.asset_library import library_dirs
from usdworld.authoring.editing.state import ObjectState, WorldState, footprints
from usdworld.io.class_table import load_class_table
from usdworld.layout import permissible as pm


def _state() -> WorldState:
    stage = Usd.Stage.CreateInMemory()
    return WorldState(stage, (stage.GetRootLayer(),), load_class_table(), library_dirs(None))


def test_a_street_lamps_rule_footprint_is_its_mast_behind_its_origin():
    state = _state()
    assert state.footprint_size("pole", "street_lamp") == pytest.approx((0.3, 0.3), abs=1e-6)
    assert state.footprint_offset("pole", "street_lamp") == pytest.approx((-0.875, 0.0), abs=1e-6)
    assert state.footprint_offset("pole", "plain") == pytest.approx((0.0, 0.0), abs=1e-9)
    assert state.footprint_offset("car", "sedan") == (0.0, 0.0)  # not a trunk class: its whole footprint


def test_a_bus_under_a_lamps_arm_does_not_overlap_the_lamp():
    # Left of the road, arm over it (yaw -90 deg: +X towards -Y); scale 1.1.
    lamp = ObjectState(
        "pole_0001", "/World/Objects/pole_0001", "pole", "street_lamp", (10.0, 5.0, 0.15), -90.0, 1.1,
        (2.255, 0.33), (0.33, 0.33), True, "base", "", (-0.9625, 0.0),
    )
    table = footprints([lamp])
    assert table.centers[0] == pytest.approx([10.0, 5.9625])  # the mast, away from the road
    # its side (y 5.15) past the lamp's origin (y 5), short of the mast (y 5.80 to 6.13)
    bus = pm.Candidate("bus", np.array([10.0, 3.9]), np.array([11.0, 2.5]), 0.0)
    assert pm.fit_violations(bus, table) == []
    closer = pm.Candidate("bus", np.array([10.0, 4.6]), np.array([11.0, 2.5]), 0.0)  # its side past the mast
    assert [v.other for v in pm.fit_violations(closer, table)] == ["pole_0001"]
