"""The shared ground rotation: known answers, its properties, and that the build and the editor use it."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from usdworld.geometry.rotation import turned

_coord = st.floats(-100.0, 100.0)
_yaw = st.floats(-4 * math.pi, 4 * math.pi)


def test_known_turns() -> None:
    np.testing.assert_allclose(turned((1.0, 0.0), math.pi / 2), [0.0, 1.0], atol=1e-15)
    np.testing.assert_allclose(turned((1.0, 2.0), math.pi), [-1.0, -2.0], atol=1e-15)
    np.testing.assert_allclose(turned(np.array([0.0, 1.0]), -math.pi / 2), [1.0, 0.0], atol=1e-15)
    assert turned((3.0, -4.0), 0.0).tolist() == [3.0, -4.0]
    assert turned((0.0, 0.0), 1.0).dtype == np.float64


@given(_coord, _coord, _yaw, _yaw)
def test_turns_keep_length_and_add_up(x: float, y: float, a: float, b: float) -> None:
    once = turned((x, y), a)
    assert math.isclose(math.hypot(*once), math.hypot(x, y), rel_tol=1e-12, abs_tol=1e-12)
    np.testing.assert_allclose(turned(once, b), turned((x, y), a + b), atol=1e-9)
    np.testing.assert_allclose(turned(once, -a), [x, y], atol=1e-9)


def test_the_build_and_the_drives_use_the_shared_rotation() -> None:
    from usdworld.layout import draft
    from usdworld.views import drive

    assert draft.turned is turned
    assert drive.turned is turned


@given(_coord, _coord, st.floats(-2.0, 2.0), st.floats(-2.0, 2.0), _yaw)
def test_the_editors_footprint_centre_is_the_origin_plus_the_turned_offset(
    x: float, y: float, ox: float, oy: float, yaw: float
) -> None:
    from usdworld.authoring.editing.state import ObjectState

    state = ObjectState(
        "tree_0001", "/World/Objects/tree_0001", "tree", "", (x, y, 0.0), 0.0, 1.0,
        (1.0, 1.0), (0.3, 0.3), True, "base", "", (ox, oy),
    )
    centre = state.footprint_centre(np.array([x, y]), yaw)
    assert centre.tolist() == (np.array([x, y]) + turned((ox, oy), yaw)).tolist()
