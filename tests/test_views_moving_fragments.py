"""A drive's mover broken into two moving tracks is joined into one; two movers are not."""

from __future__ import annotations

import numpy as np
from layout_support import ground_placement

from usdworld.parameters.views import ViewsParams
from usdworld.views.drive import _is_moving, _Track, fragments_agree, merge_moving_fragments, speed_prior
from usdworld.views.fusion import FusedObject, Observation

PARAMS = ViewsParams()
WALK = np.array([0.0, 1.4])  # m/s, across the camera's rays


def _frame(t: float, xy: np.ndarray) -> FusedObject:
    """A person's frame at ``xy`` seen from a camera at the origin (range 0.3 m, bearing 0.1 m)."""
    placement = ground_placement("person", (float(xy[0]), float(xy[1])), (100, 40, 110, 120), (0.5, 0.5, 1.7))
    o = Observation(int(round(10 * t)), "f", "f.png", placement, np.zeros(2), 0.3, 0.1)
    return FusedObject(placement, (o,), "single", o.covariance())


def _track(times: list[float], start: np.ndarray) -> _Track:
    tr = _Track("person", speed_prior("person", PARAMS))
    for t in times:
        tr.add(t, _frame(t, start + WALK * t))
    return tr


def test_a_walkers_two_fragments_are_one_track() -> None:
    """A walker at 1.4 m/s across the rays, its first second in one track and its second in another:
    both move, their fits meet where it is, and the joined track holds all twenty frames."""
    start = np.array([20.0, -1.4])
    a = _track([0.1 * k for k in range(10)], start)
    b = _track([1.0 + 0.1 * k for k in range(10)], start)
    assert _is_moving(a, a.fit, PARAMS) and _is_moving(b, b.fit, PARAMS)
    assert fragments_agree(a, b) < 0.01  # the speed prior shrinks each fit a little
    (joined,) = merge_moving_fragments([a, b], PARAMS)
    assert len(joined.times) == 20
    assert np.allclose(joined.fit.velocity, WALK, atol=1e-2)


def test_two_walkers_one_after_the_other_stay_two() -> None:
    """A second walker 3 m beside the first's path, seen after it: the fits do not meet (the gate), so the
    two tracks are kept; nor are two tracks that share a frame ever compared."""
    a = _track([0.1 * k for k in range(10)], np.array([20.0, -1.4]))
    b = _track([1.0 + 0.1 * k for k in range(10)], np.array([23.0, -1.4]))
    assert fragments_agree(a, b) > PARAMS.association_gate_chi2
    assert len(merge_moving_fragments([a, b], PARAMS)) == 2
    c = _track([0.9 + 0.1 * k for k in range(10)], np.array([20.0, -1.4]))
    assert fragments_agree(a, c) is None
    assert len(merge_moving_fragments([a, c], PARAMS)) == 2
