"""``usdworld vary``: reproducible, valid, permissible variations sharing the world's base."""

from __future__ import annotations

import pytest
from pxr import Sdf
from test_edit_support import fresh_world, sha256

from usdworld.authoring.editing.state import footprints
from usdworld.authoring.edits import WorldEditor
from usdworld.authoring.validate import errors_only, validate_file
from usdworld.authoring.variations import make_variations
from usdworld.cli.main import main
from usdworld.errors import InputError
from usdworld.layout.permissible import footprint_overlaps, load_surface_rules, surface_at


@pytest.fixture()
def world(tmp_path_factory, tmp_path):
    return fresh_world(tmp_path_factory, tmp_path / "world")


def test_variations_share_the_base_and_are_permissible(world, tmp_path):
    hashes = {
        p: sha256(p) for p in (world, world.parent / "layers/base.usda", world.parent / "layers/edits.usda")
    }
    out = tmp_path / "variations"
    variations = make_variations(world, 3, 7, out)
    assert [v.root.name for v in variations] == [
        "variation_0001.usda",
        "variation_0002.usda",
        "variation_0003.usda",
    ]
    rules = load_surface_rules()
    for v in variations:
        layer = Sdf.Layer.FindOrOpen(str(v.root))
        assert list(layer.subLayerPaths) == [
            v.edits.name,
            "../world/layers/edits.usda",
            "../world/layers/base.usda",
        ]
        assert layer.defaultPrim == "World"
        assert layer.pseudoRoot.GetInfo("upAxis") == "Z" and layer.pseudoRoot.GetInfo("metersPerUnit") == 1.0
        assert len(v.applied) >= 1
        with WorldEditor(v.root) as editor:
            history = editor.history()
            assert len(history) == len(v.applied) and all(h.time == "" and not h.forced for h in history)
            objects = editor.objects()
            assert footprint_overlaps(footprints(objects)) == []
            touched = [o for o in objects if o.active and o.status in ("added", "edited")]
            names, _ = surface_at([o.position_world[:2] for o in touched], editor.ground())
            for o, surface in zip(touched, names):
                assert surface in rules.for_class(o.class_name), o
    for path, digest in hashes.items():
        assert sha256(path) == digest


def test_variations_validate_with_no_errors(world, tmp_path):
    for v in make_variations(world, 2, 11, tmp_path / "v"):
        assert errors_only(validate_file(v.root)) == []


def test_same_seed_same_bytes_other_seed_differs(world, tmp_path):
    a = make_variations(world, 3, 7, tmp_path / "a")
    b = make_variations(world, 3, 7, tmp_path / "b")
    c = make_variations(world, 3, 8, tmp_path / "c")
    for x, y in zip(a, b):
        assert x.root.read_bytes() == y.root.read_bytes() and x.edits.read_bytes() == y.edits.read_bytes()
    assert [x.edits.read_bytes() for x in a] != [z.edits.read_bytes() for z in c]


def test_a_variation_can_be_edited_further(world, tmp_path):
    (v,) = make_variations(world, 1, 3, tmp_path / "v")
    before = sha256(world.parent / "layers/edits.usda")
    with WorldEditor(v.root) as editor:
        name = next(o.name for o in editor.objects() if o.active)
        editor.delete(name)
    assert sha256(world.parent / "layers/edits.usda") == before
    layer = Sdf.Layer.FindOrOpen(str(v.edits))
    assert layer.GetPrimAtPath(f"/World/Objects/{name}").active is False


def test_vary_cli(world, tmp_path, capsys):
    out = tmp_path / "vars"
    code = main(["vary", str(world), "-n", "2", "--seed", "5", "-o", str(out)])
    stdout, stderr = capsys.readouterr()
    lines = stdout.splitlines()
    assert code == 0 and stderr == ""
    assert lines[0].startswith(f"{out / 'variation_0001.usda'}: ") and lines[0].endswith(" edit(s)")
    assert lines[-1] == f"wrote 2 variation(s) to {out}"
    assert sorted(p.name for p in out.iterdir()) == [
        "variation_0001.edits.usda",
        "variation_0001.usda",
        "variation_0002.edits.usda",
        "variation_0002.usda",
    ]


def test_bad_arguments(world, tmp_path):
    with pytest.raises(InputError, match="-n: must be >= 1, got 0"):
        make_variations(world, 0, 1, tmp_path / "v")
    with pytest.raises(InputError, match="no such world"):
        make_variations(tmp_path / "none.usda", 1, 1, tmp_path / "v")
