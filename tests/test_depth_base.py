"""Tests for usdworld.perception.depth: DepthPrediction, the factory, lazy torch import."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from usdworld.errors import CalibrationError, InputError
from usdworld.perception.depth import BACKEND_NAMES, DepthBackend, DepthPrediction, make_backend

ROOT = Path(__file__).parents[1]


def test_prediction_masks_nan_inf_and_non_positive() -> None:
    depth = np.array([[1.0, np.nan, np.inf], [0.0, -2.0, 3.0]])
    pred = DepthPrediction(depth=depth, valid=np.ones((2, 3), bool), name="x", kind="metric")
    np.testing.assert_array_equal(pred.valid, [[True, False, False], [False, False, True]])
    np.testing.assert_array_equal(pred.depth, [[1.0, 0.0, 0.0], [0.0, 0.0, 3.0]])
    assert pred.depth.dtype == np.float32 and not pred.depth.flags.writeable
    assert pred.shape == (2, 3)


def test_affine_invariant_keeps_negative_values_but_not_nan() -> None:
    pred = DepthPrediction(
        depth=np.array([[-1.0, np.nan]]), valid=np.ones((1, 2), bool), name="x", kind="affine_invariant"
    )
    np.testing.assert_array_equal(pred.valid, [[True, False]])
    assert pred.depth[0, 0] == -1.0


def test_prediction_rejects_bad_kind_and_shapes() -> None:
    with pytest.raises(InputError, match="kind must be one of"):
        DepthPrediction(depth=np.ones((2, 2)), valid=np.ones((2, 2), bool), name="x", kind="metres")  # type: ignore[arg-type]
    with pytest.raises(InputError, match=r"must be \(H, W\) of one shape"):
        DepthPrediction(depth=np.ones((2, 2)), valid=np.ones((2, 3), bool), name="x", kind="metric")


def test_to_depth_map_only_for_metric() -> None:
    pred = DepthPrediction(depth=np.full((2, 2), 4.0), valid=np.ones((2, 2), bool), name="m", kind="metric")
    dm = pred.to_depth_map()
    assert dm.source == "m" and float(dm.depth_m[0, 0]) == 4.0
    rel = DepthPrediction(depth=np.full((2, 2), 4.0), valid=np.ones((2, 2), bool), name="r", kind="relative")
    with pytest.raises(CalibrationError, match="depth from r is relative, not metres"):
        rel.to_depth_map()


def test_factory_names_and_errors(tmp_path: Path) -> None:
    assert BACKEND_NAMES == ("ground", "monodepth", "monodepth2", "hf", "file")
    assert isinstance(make_backend("ground", None), DepthBackend)
    with pytest.raises(InputError, match=r"^depth backend 'midas': unknown; choose one of ground, monodepth"):
        make_backend("midas", None)
    with pytest.raises(InputError, match="depth backend ground: takes no weights"):
        make_backend("ground", tmp_path)
    with pytest.raises(InputError, match=r"depth backend file: needs the depth map file"):
        make_backend("file", None)


def test_package_imports_without_torch() -> None:
    code = (
        "import sys; sys.modules['torch'] = None; sys.modules['transformers'] = None\n"
        "import usdworld.perception.depth as d\n"
        "from usdworld.perception.depth import align, fusion, ground, file, runtime\n"
        "assert 'torch' not in [m for m in sys.modules if sys.modules[m] is not None]\n"
        "try:\n"
        "    d.make_backend('monodepth', None)\n"
        "except d.InputError as e:\n"
        "    print(e)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.startswith("monodepth: needs PyTorch, which is not installed: pip install torch (")
