"""Shared fixtures and settings for the test suite."""

from __future__ import annotations

import os
from pathlib import Path

# OpenUSD destroys a released layer's data on a detached worker thread; a process that holds a
# stage until it exits (a probe's globals, a pytest worker) can then run the libraries' static
# destructors beside that thread, and it aborts ("pure virtual method called"). The suite and
# every process it starts (they inherit the environment) destroy synchronously instead, set
# before pxr is first imported; TF_ENV_SETTING_ALERTS_ENABLED=0 keeps OpenUSD's banner about an
# overridden setting off stderr, which tests read. (The ``usdworld`` command itself never tears
# its interpreter down: usdworld.cli.main.run.)
os.environ.setdefault("WORK_SYNCHRONIZE_ASYNC_DESTROY_CALLS", "1")
os.environ.setdefault("TF_ENV_SETTING_ALERTS_ENABLED", "0")

import pytest  # noqa: E402
from hypothesis import HealthCheck, settings  # noqa: E402

import usdworld.authoring  # noqa: F401, E402  (registers the schema plugin before any stage is opened)
from usdworld.resources import evaluation_data_dir  # noqa: E402

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
