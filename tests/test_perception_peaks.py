"""The crowns' peak finder (perception.peaks) against scipy.signal.find_peaks, its reference."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.perception.peaks import local_maxima, prominences

signal = pytest.importorskip("scipy.signal", reason="scipy is the reference the peak finder is checked against")

# Small integer levels make plateaus, equal peaks and equal bases common; the crowns'
# profiles are such pixel counts (or interpolated between them: the float case).
levels = st.lists(st.integers(0, 6), min_size=0, max_size=40)
floats = st.lists(st.floats(-50.0, 50.0, allow_nan=False, width=32), min_size=0, max_size=40)


def _check(values: list[float]) -> None:
    x = np.asarray(values, dtype=np.float64)
    expected, props = signal.find_peaks(x, prominence=0.0)
    peaks = local_maxima(x)
    np.testing.assert_array_equal(peaks, expected)
    # Exactly equal: the crowns' cut compares prominences with thresholds.
    np.testing.assert_array_equal(prominences(x, peaks), props["prominences"])


@settings(max_examples=400, deadline=None)
@given(levels)
def test_matches_scipy_on_plateaus(values: list[int]):
    _check([float(v) for v in values])


@settings(max_examples=300, deadline=None)
@given(floats)
def test_matches_scipy_on_real_values(values: list[float]):
    _check(values)


def test_known_answers():
    # A plateau's peak is its middle (the left middle of an even run); ends are never peaks.
    x = np.array([0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 5.0, 2.0, 3.0, 2.0, 9.0])
    assert local_maxima(x).tolist() == [2, 6, 8]
    # The plateau is 1 above 0 on both sides; the 5 at 6 has bases 0 (left, to the signal's
    # start) and 2 (right, before the higher 9): 5 - 2; the 3 at 8 has bases 2 and 2.
    assert prominences(x, local_maxima(x)).tolist() == [1.0, 3.0, 1.0]


def test_crowns_do_not_import_scipy_signal():
    code = "import sys, usdworld.perception.objects; print('scipy.signal' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
