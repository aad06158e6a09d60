"""Golden ``.usda`` text for one small fixed scene (regenerate with tools/regen_golden.py)."""

from __future__ import annotations

import difflib

import pytest
from golden_scene import GOLDEN_DIR, GOLDEN_FILES, build_golden


@pytest.fixture(scope="module")
def texts(tmp_path_factory):
    return build_golden(tmp_path_factory.mktemp("golden"))


@pytest.mark.parametrize("name", GOLDEN_FILES)
def test_layer_matches_golden(texts, name):
    expected = (GOLDEN_DIR / name.replace("/", "__")).read_text()
    if texts[name] != expected:
        diff = "".join(
            difflib.unified_diff(
                expected.splitlines(True), texts[name].splitlines(True), "golden", "built", n=2
            )
        )
        pytest.fail(f"{name} differs from its golden copy (run tools/regen_golden.py if intended):\n{diff[:4000]}")
