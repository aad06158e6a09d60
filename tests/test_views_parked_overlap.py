"""A drive's standing vehicle tracks whose footprints must overlap are one vehicle."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from layout_support import ground_placement

from usdworld.parameters.views import ViewsParams
from usdworld.perception.depth.fusion import DepthCue
from usdworld.views.drive import track_drive
from usdworld.views.fusion import Observation

PARAMS = ViewsParams()
TIMES = [0.1 * k for k in range(10)]


def _car(frame: int, xy: tuple[float, float], sigma_r: float, sigma_l: float, ref: int) -> Observation:
    """A car (4.5 x 1.8 m) seen in ``frame`` (one view per frame) from a camera at the origin."""
    x, y = xy
    cue = DepthCue("contact", float(np.hypot(x, y)), sigma_r)
    placement = ground_placement("car", xy, (100, 40, 140, 70), (4.5, 1.8, 1.5), cues=(cue,), ref=ref)
    return Observation(frame, f"f{frame}", f"f{frame}.png", placement, np.zeros(2), sigma_r, sigma_l)


def test_a_parked_car_placed_off_in_a_few_frames_is_one_car() -> None:
    """A parked row: car A at (14, 5), car B at (20, 5), both seen in frames 0-9 (sure to 0.5 m along
    the ray, 0.3 m across). In frames 4-6 the view places B 1.4 m towards the road (a hidden side it
    did not see, stated as sure as the others: 4.7 sigma across, outside the gate), and in frame 5 it
    also sees B where it is (its mask cut in two). Those three frames make a fragment that shares
    frame 5 with B's own track, so joining fragments that share no frame leaves three cars. Their
    placed positions are 1.2 m apart, nearer than the 1.8 m two car widths' halves reach: one car."""
    obs = [_car(k, (14.0, 5.0), 0.5, 0.3, ref=1) for k in range(10)]
    obs += [_car(k, (20.0, 5.0), 0.5, 0.3, ref=2) for k in range(10) if k not in (4, 6)]
    obs += [_car(k, (20.0, 3.6), 0.5, 0.3, ref=3) for k in (4, 5, 6)]
    objects = track_drive(obs, TIMES, PARAMS)
    assert not any(o.moving for o in objects)
    cars = sorted(objects, key=lambda o: o.fused.placement.contact_world[0])
    assert [len(o.times) for o in cars] == [10, 10]
    assert len(cars[1].fused.observations) == 11
    assert cars[0].fused.placement.contact_world[:2] == pytest.approx([14.0, 5.0])
    assert cars[1].fused.placement.contact_world[0] == pytest.approx(20.0, abs=0.05)
    assert 3.6 < cars[1].fused.placement.contact_world[1] < 5.0


@settings(max_examples=30, deadline=None)
@given(
    across=st.one_of(st.floats(0.3, 1.7), st.floats(1.9, 4.0)),
    along=st.floats(-0.5, 0.5),
)
def test_two_cars_in_every_frame_are_one_exactly_when_their_footprints_must_overlap(
    across: float, along: float
) -> None:
    """Two standing cars (1.8 m wide) seen in every frame, precisely (0.1 m), are two tracks that share
    every frame. They are one car when their centres are nearer than the sum of their inscribed discs'
    radii (1.8 m: they would overlap whatever their headings), else two cars, each where it is."""
    a, b = (30.0, 4.0), (30.0 + along, 4.0 - across)
    obs = [_car(k, xy, 0.1, 0.1, ref=r) for k in range(10) for r, xy in ((1, a), (2, b))]
    objects = track_drive(obs, TIMES, PARAMS)
    assert not any(o.moving for o in objects)
    if np.hypot(across, along) < 1.8:
        assert len(objects) == 1 and len(objects[0].fused.observations) == 20
        assert objects[0].fused.placement.contact_world[:2] == pytest.approx(np.add(a, b) / 2, abs=1e-6)
    else:
        got = sorted((o.fused.placement.contact_world[:2] for o in objects), key=lambda xy: -xy[1])
        assert len(got) == 2
        assert got[0] == pytest.approx(a) and got[1] == pytest.approx(b)
