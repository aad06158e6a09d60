"""The codeless UsdWorld schemas: fresh generated files, registration, life without the plugin."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from pxr import Usd

REPO = Path(__file__).resolve().parents[1]


def test_generated_schema_files_are_fresh():
    pytest.importorskip("jinja2", reason="usdGenSchema needs jinja2 (pip install -e '.[test]')")
    result = subprocess.run([sys.executable, str(REPO / "tools/gen_schema.py"), "--check"], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr


def test_schemas_registered_on_import():
    reg = Usd.SchemaRegistry()
    assert reg.IsAppliedAPISchema("UsdWorldProvenanceAPI")
    assert reg.IsAppliedAPISchema("UsdWorldSceneAPI")
    definition = reg.FindAppliedAPIPrimDefinition("UsdWorldProvenanceAPI")
    assert "usdworld:depth" in definition.GetPropertyNames()


def test_world_opens_without_the_plugin(tmp_path):
    from golden_scene import write_inputs

    from usdworld.pipeline import build

    world = build(write_inputs(tmp_path)).world
    code = (
        "from pxr import Usd; import sys; s = Usd.Stage.Open(sys.argv[1]); "
        "p = s.GetPrimAtPath('/World/Objects/car_0001'); "
        "assert 'UsdWorldProvenanceAPI' not in p.GetAppliedSchemas(); "
        "assert 'UsdWorldProvenanceAPI' in p.GetMetadata('apiSchemas').GetAddedOrExplicitItems(); "
        "print(p.GetAttribute('usdworld:depth').Get(), p.GetAttribute('usdworld:depthMethod').Get())"
    )
    result = subprocess.run([sys.executable, "-c", code, str(world)], capture_output=True, text=True, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    depth, method = result.stdout.split()
    assert float(depth) > 0 and method == "contact"
    assert "Warning" not in result.stderr
