"""report.json -> camera -> lanes and roll: what measured the height and the roll, and how sure."""

from __future__ import annotations

import math

import numpy as np
import pytest

from usdworld.geometry.lanes import LaneWidthCue
from usdworld.geometry.roll import RollMeasurement, fuse_roll
from usdworld.report import _lanes_entry, _roll_entry


def test_the_lanes_entry_records_each_pair_and_the_height_it_implies():
    cue = LaneWidthCue(np.array([2.0, 2.1]), np.array([0.05, 0.06]), 0.0, 3.25, 0.09, 0.5, math.log(8.0))
    entry = _lanes_entry(cue)
    assert entry["pairs"] == 2
    assert entry["implied_height_m"] == pytest.approx([1.625, 3.25 / 2.1], abs=1e-6)
    assert entry["sigma_log"] == [0.05, 0.06]
    assert _lanes_entry(None) is None


def test_the_roll_entry_says_whether_the_measurement_was_used():
    measured = RollMeasurement(math.radians(1.0), math.radians(1.0), "the vertical of 9 upright segments")
    used = _roll_entry(fuse_roll(measured))
    assert used["used"] is True
    assert used["measured_deg"] == pytest.approx(1.0)
    assert 0.0 < used["roll_deg"] < 1.0
    dropped = _roll_entry(fuse_roll(RollMeasurement(math.radians(12.0), math.radians(0.5), "a facade")))
    assert dropped["used"] is False and dropped["roll_deg"] == 0.0
    assert dropped["measured_deg"] == pytest.approx(12.0)
    none = _roll_entry(fuse_roll(None))
    assert none["measured_deg"] is None and none["source"] == ""
    assert _roll_entry(None) is None
