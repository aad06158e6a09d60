"""Shared fixtures and settings for the test suite."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

import usdworld.authoring  # noqa: F401  (registers the schema plugin before any stage is opened)
from usdworld.resources import evaluation_data_dir

settings.register_profile("ci", max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

REPO = Path(__file__).resolve().parents[1]
#: The real evaluation data: $USDWORLD_DATA, else ../shared/data beside the checkout.
SHARED_DATA = evaluation_data_dir()


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The real evaluation data ($USDWORLD_DATA or ../shared/data); skips the test when it is absent."""
    if not SHARED_DATA.is_dir():
        pytest.skip(
            f"real evaluation data not found at {SHARED_DATA} (non-commercial data kept outside the repo; "
            "set USDWORLD_DATA to another copy)"
        )
    return SHARED_DATA
