"""Colour spaces and colour differences: published known answers and properties."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.evaluation.colour_difference import delta_e76, delta_e2000
from usdworld.perception.colour_space import linear_to_lab, linear_to_srgb, srgb_to_linear, uint8_to_linear

#: Sharma, Wu and Dalal (2005), Table 1: L1 a1 b1, L2 a2 b2, CIEDE2000 (all 34 pairs).
SHARMA_2005 = np.array(
    [
        [50.0000, 2.6772, -79.7751, 50.0000, 0.0000, -82.7485, 2.0425],
        [50.0000, 3.1571, -77.2803, 50.0000, 0.0000, -82.7485, 2.8615],
        [50.0000, 2.8361, -74.0200, 50.0000, 0.0000, -82.7485, 3.4412],
        [50.0000, -1.3802, -84.2814, 50.0000, 0.0000, -82.7485, 1.0000],
        [50.0000, -1.1848, -84.8006, 50.0000, 0.0000, -82.7485, 1.0000],
        [50.0000, -0.9009, -85.5211, 50.0000, 0.0000, -82.7485, 1.0000],
        [50.0000, 0.0000, 0.0000, 50.0000, -1.0000, 2.0000, 2.3669],
        [50.0000, -1.0000, 2.0000, 50.0000, 0.0000, 0.0000, 2.3669],
        [50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0009, 7.1792],
        [50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0010, 7.1792],
        [50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0011, 7.2195],
        [50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0012, 7.2195],
        [50.0000, -0.0010, 2.4900, 50.0000, 0.0009, -2.4900, 4.8045],
        [50.0000, -0.0010, 2.4900, 50.0000, 0.0010, -2.4900, 4.8045],
        [50.0000, -0.0010, 2.4900, 50.0000, 0.0011, -2.4900, 4.7461],
        [50.0000, 2.5000, 0.0000, 50.0000, 0.0000, -2.5000, 4.3065],
        [50.0000, 2.5000, 0.0000, 73.0000, 25.0000, -18.0000, 27.1492],
        [50.0000, 2.5000, 0.0000, 61.0000, -5.0000, 29.0000, 22.8977],
        [50.0000, 2.5000, 0.0000, 56.0000, -27.0000, -3.0000, 31.9030],
        [50.0000, 2.5000, 0.0000, 58.0000, 24.0000, 15.0000, 19.4535],
        [50.0000, 2.5000, 0.0000, 50.0000, 3.1736, 0.5854, 1.0000],
        [50.0000, 2.5000, 0.0000, 50.0000, 3.2972, 0.0000, 1.0000],
        [50.0000, 2.5000, 0.0000, 50.0000, 1.8634, 0.5757, 1.0000],
        [50.0000, 2.5000, 0.0000, 50.0000, 3.2592, 0.3350, 1.0000],
        [60.2574, -34.0099, 36.2677, 60.4626, -34.1751, 39.4387, 1.2644],
        [63.0109, -31.0961, -5.8663, 62.8187, -29.7946, -4.0864, 1.2630],
        [61.2901, 3.7196, -5.3901, 61.4292, 2.2480, -4.9620, 1.8731],
        [35.0831, -44.1164, 3.7933, 35.0232, -40.0716, 1.5901, 1.8645],
        [22.7233, 20.0904, -46.6940, 23.0331, 14.9730, -42.5619, 2.0373],
        [36.4612, 47.8580, 18.3852, 36.2715, 50.5065, 21.2231, 1.4146],
        [90.8027, -2.0831, 1.4410, 91.1528, -1.6435, 0.0447, 1.4441],
        [90.9257, -0.5406, -0.9208, 88.6381, -0.8985, -0.7239, 1.5381],
        [6.7747, -0.2908, -2.4247, 5.8714, -0.0985, -2.2286, 0.6377],
        [2.0776, 0.0795, -1.1350, 0.9033, -0.0636, -0.5514, 0.9082],
    ]
)

lab_values = st.tuples(st.floats(0, 100), st.floats(-128, 127), st.floats(-128, 127)).map(
    lambda t: np.array(t, dtype=np.float64)
)


def test_ciede2000_reproduces_the_sharma_table():
    got = delta_e2000(SHARMA_2005[:, :3], SHARMA_2005[:, 3:6])
    np.testing.assert_allclose(got, SHARMA_2005[:, 6], atol=5e-5)


def test_ciede2000_is_symmetric_on_the_sharma_table():
    np.testing.assert_allclose(
        delta_e2000(SHARMA_2005[:, 3:6], SHARMA_2005[:, :3]), SHARMA_2005[:, 6], atol=5e-5
    )


def test_ciede2000_of_greys_is_their_lightness_difference_weighted():
    # achromatic pair: only the lightness term, SL at mean L = 50 is 1
    assert delta_e2000(np.array([45.0, 0, 0]), np.array([55.0, 0, 0])) == pytest.approx(10.0)
    assert delta_e2000(np.zeros(3), np.zeros(3)) == 0.0


def test_delta_e76_is_euclidean():
    assert delta_e76(np.array([50.0, 3, 4]), np.array([50.0, 0, 0])) == pytest.approx(5.0)
    assert delta_e76(np.zeros((2, 3)), np.array([[0, 0, 12.0], [3, 4, 0]])).tolist() == [12.0, 5.0]


@settings(max_examples=60, deadline=None)
@given(lab_values, lab_values)
def test_colour_differences_are_symmetric_and_non_negative(a, b):
    assert delta_e2000(a, b) == pytest.approx(delta_e2000(b, a), abs=1e-9)
    assert delta_e2000(a, b) >= 0.0 and delta_e76(a, b) >= 0.0
    assert delta_e2000(a, a) == pytest.approx(0.0, abs=1e-9)


def test_lab_known_answers():
    # white, black and the sRGB red primary (published CIELAB of sRGB #ff0000: 53.24, 80.09, 67.20)
    np.testing.assert_allclose(linear_to_lab(np.array([1.0, 1.0, 1.0])), [100, 0, 0], atol=1e-6)
    np.testing.assert_allclose(linear_to_lab(np.zeros(3)), [0, 0, 0], atol=1e-9)
    np.testing.assert_allclose(linear_to_lab(np.array([1.0, 0.0, 0.0])), [53.24, 80.09, 67.20], atol=0.02)


def test_srgb_transfer_round_trips_and_known_values():
    s = np.linspace(0, 1, 257)
    np.testing.assert_allclose(linear_to_srgb(srgb_to_linear(s)), s, atol=1e-12)
    assert srgb_to_linear(np.array(0.5)) == pytest.approx(0.214041, abs=1e-6)
    assert uint8_to_linear(np.array([255, 0, 128], dtype=np.uint8)).tolist()[:2] == [1.0, 0.0]
