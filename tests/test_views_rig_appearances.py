"""The first view's measured looks follow its objects into a rig's world, whose names are the rig's."""

from __future__ import annotations

import dataclasses

import numpy as np
from test_views_bearings import _seen

from usdworld.layout.model import Appearance
from usdworld.perception.appearance import MeasuredColour
from usdworld.views.build import rig_appearances
from usdworld.views.fusion import FusedObject, Observation


def _look(target: str, kind: str, grey: float) -> Appearance:
    colour = MeasuredColour(np.full(3, grey), np.zeros(3), 100, "box")
    return Appearance(target, kind, colour, np.full(3, grey))


def _named(o: Observation, name: str) -> Observation:
    return dataclasses.replace(o, placement=dataclasses.replace(o.placement, name=name))


def _fused(name: str, *members: Observation) -> FusedObject:
    placement = dataclasses.replace(members[0].placement, name=name)
    return FusedObject(placement, tuple(members), "fused", np.eye(2))


def test_the_first_views_looks_are_renamed_to_the_rig_objects_that_hold_its_observations() -> None:
    """View 0 named three trees tree_0001-0003 and measured each a grey; the rig joined its
    tree_0001 and tree_0002 (one tree its view cut in two) into tree_0002 and calls its
    tree_0003 tree_0001; a fourth rig tree only view 1 saw. Each rig tree gets the look of its
    first view-0 observation, the joined one a single look, the unseen one none, and the road
    keeps its own: no look names a tree the rig does not have (view 0's tree_0003)."""
    a, b, c = (
        _named(_seen(0, (0.0, 0.0), (20.0, y), 0.0, cls="tree"), f"tree_000{k}")
        for k, y in ((1, 5.0), (2, 6.0), (3, -5.0))
    )
    d = _named(_seen(1, (1.0, 0.0), (30.0, 5.0), 0.0, cls="tree"), "tree_0001")
    objects = [_fused("tree_0001", c), _fused("tree_0002", a, b), _fused("tree_0003", d)]
    first = [
        _look("tree_0001", "object", 0.1),
        _look("tree_0002", "object", 0.2),
        _look("tree_0003", "object", 0.3),
        _look("road", "surface", 0.5),
    ]
    got = {(x.target, x.kind): float(x.albedo[0]) for x in rig_appearances(first, objects)}
    assert got == {("tree_0002", "object"): 0.1, ("tree_0001", "object"): 0.3, ("road", "surface"): 0.5}
