"""Top shape of a silhouette (perception.shape) and of the library's variants."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.authoring.asset_measures import variant_measures
from usdworld.layout.asset_sizes import AssetSizes, choose_variant
from usdworld.parameters.placement import PlacementParams
from usdworld.perception.shape import top_shape_ratio


def _cone(rows: int, half_width_per_row: float) -> np.ndarray:
    r = np.arange(rows)[:, None]
    c = np.arange(-rows, rows + 1)[None, :]
    return np.abs(c) <= r * half_width_per_row


def _disc(radius: int) -> np.ndarray:
    y, x = np.mgrid[-radius : radius + 1, -radius : radius + 1]
    return x * x + y * y <= radius * radius


@settings(max_examples=30, deadline=None)
@given(rows=st.integers(40, 200), slope=st.floats(0.2, 0.6), hidden=st.floats(0.0, 0.6))
def test_a_cone_keeps_its_ratio_when_its_bottom_is_hidden(rows: int, slope: float, hidden: float):
    cone = _cone(rows, slope)
    # At least 30 rows stay in view: fewer are too coarse for 20 % (20 rows can be 26 % off).
    cut = cone[: max(30, int(rows * (1 - hidden)))]
    expected = 1.0 / (4 * slope)  # half the width is reached half way down
    assert top_shape_ratio(cone) == pytest.approx(expected, rel=0.15)
    assert top_shape_ratio(cut) == pytest.approx(expected, rel=0.2)


def test_round_top_is_near_zero_and_empty_is_none():
    assert top_shape_ratio(_disc(40)) < 0.1
    assert top_shape_ratio(np.zeros((5, 5), bool)) is None


def test_a_mask_one_or_two_pixels_wide_has_no_top_shape():
    """Every row of a 1-2 px wide mask is at least half its widest: the ratio would be 0.5 / widest
    (0.25 for 2 px, a street lamp's side of the plain pole's), so there is none; from 3 px on a
    1 px top row no longer counts and the shape is read."""
    plain_pole = np.zeros((90, 4), bool)
    plain_pole[:, 1:3] = True  # 2 px wide all the way down
    assert top_shape_ratio(plain_pole) is None
    assert top_shape_ratio(plain_pole[:, 1:2]) is None
    based = plain_pole.copy()
    based[80:, 0:3] = True  # a 3 px base under a 2 px shaft: the shaft counts as half
    assert top_shape_ratio(based) == pytest.approx(0.5 / 3)
    tapered = np.zeros((90, 5), bool)
    tapered[:, 2] = True
    tapered[60:, 1:4] = True  # 1 px top, 3 px from row 60
    assert top_shape_ratio(tapered) == pytest.approx(60.5 / 3)


def test_library_variants_are_told_apart():
    conifer = variant_measures("tree", "conifer").top_shape
    deciduous = variant_measures("tree", "deciduous").top_shape
    assert conifer > 0.5 and deciduous < 0.1
    assert (
        variant_measures("pole", "plain").top_shape > 1.0 > variant_measures("pole", "street_lamp").top_shape
    )


def test_variant_chosen_by_top_shape_when_height_is_unknown():
    sizes = AssetSizes(
        {"conifer": (3.0, 3.0, 8.0), "deciduous": (4.0, 4.0, 7.0)},
        "deciduous",
        top_shape_by_variant={"conifer": 1.06, "deciduous": 0.04},
    )
    hidden_cone = _cone(120, 0.25)[:70]  # a conifer whose lower half a car hides
    assert (
        choose_variant(
            sizes,
            float("nan"),
            float("nan"),
            0.0,
            top_shape_ratio(hidden_cone),
            PlacementParams().top_shape_offset,
        )
        == "conifer"
    )
    assert (
        choose_variant(
            sizes,
            float("nan"),
            float("nan"),
            0.0,
            top_shape_ratio(_disc(30)),
            PlacementParams().top_shape_offset,
        )
        == "deciduous"
    )
    assert (
        choose_variant(sizes, float("nan"), float("nan"), 0.0, None, PlacementParams().top_shape_offset)
        == "deciduous"
    )


def test_mean_contact_reach_of_a_person_is_below_its_largest_half_extent():
    m = variant_measures("person", "walking")
    assert 0.0 < m.contact_mean_reach < max(m.contact_half)


def test_car_contact_is_the_tyre_bottoms_not_their_curve():
    m = variant_measures("car", "hatchback")
    assert m.contact_half == pytest.approx((1.291, 0.88), abs=0.01)  # axles at +-1.25..1.29 m
    assert m.top_half[0] < m.contact_half[0] + 0.5
