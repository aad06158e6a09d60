"""A drive's short standing trunk fragments on the bearing of a longer track are that track's object."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from layout_support import ground_placement

from usdworld.parameters.views import ViewsParams
from usdworld.perception.depth.fusion import DepthCue
from usdworld.views.drive import track_drive
from usdworld.views.fusion import Observation

PARAMS = ViewsParams()
TREE = (30.0, 6.0)


def _seen(
    frame: int, camera_x: float, xy: tuple[float, float], sigma_r: float, footprint: float = 2.6
) -> Observation:
    """A tree (square ``footprint`` metres wide) placed at ``xy`` in ``frame`` by a camera at
    (camera_x, 0)."""
    camera = np.array([camera_x, 0.0])
    cue = DepthCue("contact", float(np.linalg.norm(np.asarray(xy) - camera)), sigma_r)
    placement = ground_placement("tree", xy, (100, 40, 104, 160), (footprint, footprint, 6.0), cues=(cue,))
    return Observation(frame, f"f{frame}", f"f{frame}.png", placement, camera, sigma_r, 0.3)


def _on_ray(
    camera_x: float, xy: tuple[float, float], factor: float, sideways: float = 0.0
) -> tuple[float, float]:
    """The point ``factor`` times as far as ``xy`` from the camera at (camera_x, 0) on its ray, moved
    ``sideways`` metres across it."""
    camera = np.array([camera_x, 0.0])
    d = np.asarray(xy) - camera
    n = np.array([-d[1], d[0]]) / np.linalg.norm(d)
    p = camera + factor * d + sideways * n
    return float(p[0]), float(p[1])


def _drive(fragment_factor: float, sideways: float = 0.0) -> list:
    """Six frames (camera 0.8 m apart) place the tree where it stands; a seventh places it on its ray
    ``fragment_factor`` times too far (a depth that failed), ``sideways`` metres across the ray."""
    obs = [_seen(k, 0.8 * k, TREE, 1.0) for k in range(6)]
    obs.append(_seen(6, 4.8, _on_ray(4.8, TREE, fragment_factor, sideways), 1.0, footprint=4.0))
    return track_drive(obs, [0.1 * k for k in range(7)], PARAMS)


def test_a_one_frame_fragment_on_a_trees_bearing_is_that_tree() -> None:
    """The seventh frame's tree is 2.2 times too far on the tree's ray: outside the track's gate, so it
    starts its own track; its ray passes through the six-frame tree's footprint, so it joins it, and
    the tree stands where its bearings cross (the failed depth does not move it)."""
    (tree,) = _drive(2.2)
    assert len(tree.times) == 7
    assert np.allclose(tree.fused.placement.position_world[:2], TREE, atol=0.05)


def test_a_one_frame_tree_beside_the_bearing_stays_its_own() -> None:
    """The same frame's tree placed 8.8 m across the ray at 2.2 times the range, so that its ray passes
    the tree 4 m across (beyond both footprints' reach, 1.3 + 2.0 m), is another tree."""
    objects = _drive(2.2, sideways=8.8)
    assert len(objects) == 2
    assert sorted(len(o.times) for o in objects) == [1, 6]


@settings(max_examples=60, deadline=None)
@given(st.floats(1.5, 4.0), st.floats(-16.0, 16.0))
def test_a_short_fragment_joins_only_within_the_footprints_reach(factor: float, sideways: float) -> None:
    """Property: the fragment joins the tree exactly when its ray passes within the two footprints' reach
    across it (1.3 m + 2.0 m) of the tree, and the tree then stays on its own footprint (within its 1.3 m
    radius of where it stands: the fragment brings a bearing, not its failed depth)."""
    objects = _drive(factor, sideways)
    r = float(np.linalg.norm(np.asarray(TREE) - np.array([4.8, 0.0])))
    across = abs(sideways) * r / float(np.hypot(factor * r, sideways))  # the tree from the fragment's ray
    if across < 3.3 - 1e-6:
        (tree,) = objects
        assert np.linalg.norm(tree.fused.placement.position_world[:2] - np.asarray(TREE)) < 1.3
    else:
        assert len(objects) == 2
