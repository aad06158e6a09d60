"""A world whose base layer is missing or truncated: every command says which file, in one line, exit 2.

OpenUSD opens a stage without a sublayer it cannot read (a warning only), so without the
check the world would look empty or end in an unexpected error.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from pxr import Sdf
from test_edit_support import fresh_world, sha256

from usdworld.authoring.stages import open_stage, usd_reason
from usdworld.cli.main import main
from usdworld.errors import InputError


@pytest.fixture()
def world(tmp_path_factory, tmp_path) -> Path:
    return fresh_world(tmp_path_factory, tmp_path / "world")


def as_truncated_crate(world: Path) -> Path:
    """Rewrite the world's base layer as a crate file cut in half; returns that file."""
    text = world.parent / "layers" / "base.usda"
    crate = text.with_suffix(".usdc")
    Sdf.Layer.FindOrOpen(str(text)).Export(str(crate))
    root = Sdf.Layer.FindOrOpen(str(world))
    subs = list(root.subLayerPaths)
    subs[-1] = "./layers/base.usdc"
    root.subLayerPaths.clear()
    for sub in subs:
        root.subLayerPaths.append(sub)
    root.Save()
    text.unlink()
    data = crate.read_bytes()
    crate.write_bytes(data[: len(data) // 2])
    return crate


COMMANDS = (
    ("edit", "{w}", "list"),
    ("edit", "{w}", "move", "car_0001", "--by", "1,0"),
    ("info", "{w}"),
    ("export", "{w}", "--format", "usda-flat", "-o", "{out}"),
)


@pytest.mark.parametrize("command", COMMANDS, ids=lambda c: " ".join(c[:3]))
def test_a_truncated_crate_base_layer_is_named_in_one_line(world, tmp_path, capsys, command):
    crate = as_truncated_crate(world)
    edits = world.parent / "layers" / "edits.usda"
    before = sha256(edits)
    code = main([a.format(w=world, out=tmp_path / "flat.usda") for a in command])
    _, err = capsys.readouterr()
    lines = [line for line in err.splitlines() if line.startswith("error:")]
    assert code == 2
    assert len(lines) == 1 and "Traceback" not in err
    assert f"sublayer {crate} is not readable (Sdf crate file corrupt, possibly truncated" in lines[0]
    assert lines[0].endswith("; restore that file or rebuild the world")
    assert sha256(edits) == before  # nothing the user had is touched
    assert not (tmp_path / "flat.usda").exists()


def test_a_missing_base_layer_is_named(world, capsys):
    base = world.parent / "layers" / "base.usda"
    base.unlink()
    assert main(["edit", str(world), "list"]) == 2
    assert capsys.readouterr().err == (
        f"error: {world}: sublayer {base} is missing; restore that file or rebuild the world\n"
    )


def test_open_stage_of_an_intact_world_passes(world):
    stage = open_stage(world, "USD world")
    assert stage.GetPrimAtPath("/World/Objects/car_0001")


def test_usd_reason_keeps_only_the_reason():
    text = "\n\tError in 'pxr::Foo::_Bar' at line 1 in file /x/y.cpp : 'the reason: a (b)'"
    assert usd_reason(RuntimeError(text)) == "the reason: a (b)"
    assert usd_reason(RuntimeError("first line\nplain message")) == "plain message"
    assert usd_reason(RuntimeError("")) == "RuntimeError"
    with pytest.raises(InputError, match="not a readable USD stage"):
        open_stage(Path("/nonexistent/world.usda"))
