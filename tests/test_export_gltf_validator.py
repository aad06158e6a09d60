"""The glb export passes the Khronos glTF validator (npm gltf-validator, run with node).

Zero errors is required; the export is also expected to be free of warnings, infos and
hints (bufferView targets set, no zero-length normals, no degenerate triangles). Missing
node or web/node_modules/gltf-validator fails in CI and skips elsewhere, with the hint.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from test_export_fixtures import add_edits, build_street_world, require_web_tools

from usdworld.cli.main import main as cli
from usdworld.export import export_world
from usdworld.export.checks import run_gltf_validator


@pytest.fixture(scope="module")
def glb(tmp_path_factory: pytest.TempPathFactory) -> Path:
    require_web_tools(("gltf-validator",))
    work = tmp_path_factory.mktemp("gltf")
    root = build_street_world(work / "street")
    add_edits(root)
    return export_world(root, "glb", work / "world.glb", validate=False).output


def test_khronos_validator_finds_nothing(glb: Path) -> None:
    report = run_gltf_validator(glb)
    issues = report["issues"]
    assert issues["numErrors"] == 0, issues["messages"][:10]
    assert (issues["numWarnings"], issues["numInfos"], issues["numHints"]) == (0, 0, 0), issues["messages"][:10]
    assert report["info"]["version"] == "2.0" and report["info"]["hasDefaultScene"]


def test_cli_export_glb_runs_the_validator(glb: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    world = glb.parent / "street" / "world"
    out = tmp_path / "w.glb"
    assert cli(["export", str(world), "--format", "glb", "-o", str(out)]) == 0
    assert capsys.readouterr().out.splitlines() == [f"wrote {out}", "gltf-validator: 0 errors, 0 warning(s)"]
