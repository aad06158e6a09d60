"""``usdworld.evaluation.world_objects``: what an object's prim says, read from the composed stage."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom

from usdworld.evaluation.world_objects import world_objects


def test_an_object_s_variant_and_scale_are_read() -> None:
    """A pole with its ``model`` variant set to the street lamp and scale 1.1: both come back (a
    trunk's foot lies ``contact_offset * scale`` from its origin, ``usdworld.evaluation.drive.foot_offset``);
    an object without a variant set has ''."""
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    pole = UsdGeom.Xform.Define(stage, "/World/Objects/pole_0001")
    sets = pole.GetPrim().GetVariantSets().AddVariantSet("model")
    for v in ("plain", "street_lamp"):
        sets.AddVariant(v)
    sets.SetVariantSelection("street_lamp")
    pole.AddTranslateOp().Set(Gf.Vec3d(20.0, -4.3, 0.15))
    pole.AddRotateZOp().Set(90.0)
    pole.AddScaleOp().Set(Gf.Vec3f(1.1, 1.1, 1.1))
    UsdGeom.Xform.Define(stage, "/World/Objects/tree_0001")
    by_name = {o.name: o for o in world_objects(stage)}
    lamp, tree = by_name["pole_0001"], by_name["tree_0001"]
    assert lamp.variant == "street_lamp" and tree.variant == ""
    assert lamp.scale == pytest.approx([1.1, 1.1, 1.1])
    assert lamp.heading_world == pytest.approx([0.0, 1.0, 0.0], abs=1e-9)
    assert lamp.bottom_centre_world == pytest.approx([20.0, -4.3, 0.15])
    assert tree.scale == pytest.approx(np.ones(3))
