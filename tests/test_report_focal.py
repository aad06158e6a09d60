"""report.json -> camera -> focal: every cue and the tilt the vanishing points imply."""

from __future__ import annotations

import numpy as np
import pytest

from usdworld.geometry.focal import FocalCue, FocalEstimate
from usdworld.report import _focal_entry


def test_the_focal_entry_records_the_tilt_and_its_source():
    cues = (FocalCue("prior", 800.0, 0.3, "p"), FocalCue("lateral_vanishing_point", 760.0, 0.15, "crossings"))
    est = FocalEstimate(770.0, 0.13, cues, tilt=(np.radians(3.0), np.radians(-1.5)), tilt_source="the vertical of 9 upright segments")
    entry = _focal_entry(est)
    assert [c["source"] for c in entry["used"]] == ["prior", "lateral_vanishing_point"]
    assert entry["tilt"]["pitch_deg"] == pytest.approx(3.0)
    assert entry["tilt"]["roll_deg"] == pytest.approx(-1.5)
    assert entry["tilt"]["source"] == "the vertical of 9 upright segments"
    assert entry["tilt"]["used"] is False
    assert _focal_entry(FocalEstimate(800.0, 0.3, cues[:1]))["tilt"] is None
