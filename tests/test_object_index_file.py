"""The editor's object index kept beside a large world's base layer (``layers/objects.index.npz``):
what the build writes is what the layers hold, a file whose layers changed is never used,
and the index with the file is the index read from the layers, edits included.

The world is the editing tests' street (three objects) written as a large world
(``large_world_min_objects`` lowered to 1).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf
from test_edit_support import write_frame

from usdworld.authoring import asset_library
from usdworld.authoring.editing.index import Opinions, merge_opinions, read_index, read_opinions
from usdworld.authoring.editing.index_file import INDEX_FILE, layers_key, load_opinions, lower_opinions
from usdworld.authoring.edits import WorldEditor
from usdworld.authoring.world import write_world
from usdworld.errors import EditRefused
from usdworld.parameters.authoring import AuthoringParams
from usdworld.world_files import BASE_CRATE_LAYER, BASE_LAYER

OBJ = "/World/Objects"


@pytest.fixture(scope="module")
def template(tmp_path_factory) -> dict[str, Path]:
    """The street written as a large world and as a small one (pristine; copy before use)."""
    from usdworld.pipeline import BuildRequest, build_model

    tmp = tmp_path_factory.mktemp("index_file")
    libraries = asset_library.library_dirs(None)
    model = build_model(BuildRequest(output=tmp / "unused", **write_frame(tmp / "frame")), libraries)
    assets = asset_library.asset_files((p.obj.class_name for p in model.placements), libraries)
    write_world(model, tmp / "large", assets, None, AuthoringParams(large_world_min_objects=1))
    write_world(model, tmp / "small", assets, None)
    return {"large": tmp / "large", "small": tmp / "small"}


@pytest.fixture()
def large(template, tmp_path) -> Path:
    shutil.copytree(template["large"], tmp_path / "w")
    return tmp_path / "w"


def _same(a: Opinions, b: Opinions) -> bool:
    return (
        a.names == b.names
        and np.array_equal(a.defined, b.defined)
        and np.array_equal(a.translate, b.translate, equal_nan=True)
        and np.array_equal(a.scale, b.scale, equal_nan=True)
        and (a.label, a.variant, a.active) == (b.label, b.variant, b.active)
        and np.array_equal(a.z_scale_yaw, b.z_scale_yaw, equal_nan=True)
        and a.asset == b.asset
        and np.array_equal(a.plain, b.plain)
    )


def _index_arrays(editor: WorldEditor, lower: Opinions | None):
    st = editor._state
    index = read_index(st.layers, st.size, st.footprint_size, st.libraries, lower)
    return index.names, index.centers, index.reach, index.placed_bounds


def test_the_build_writes_what_the_base_layer_holds(template):
    base = template["large"] / BASE_CRATE_LAYER
    kept = load_opinions(base.parent / INDEX_FILE, layers_key([base]))
    assert kept is not None and len(kept) == 3
    assert _same(kept, read_opinions([Sdf.Layer.FindOrOpen(str(base))]))
    # what the render's view stage reads instead of the specs: heights, yaws, assets, plain objects
    assert kept.plain.all() and not np.isnan(kept.z_scale_yaw).any()
    assert all(a is not None and a.startswith("../assets/") for a in kept.asset)
    # a small world keeps its text base layer and gets no file
    assert not (template["small"] / "layers" / INDEX_FILE).exists()
    assert (template["small"] / BASE_LAYER).is_file()


def test_a_file_whose_base_layer_changed_is_not_used(large):
    base = large / BASE_CRATE_LAYER
    layer = Sdf.Layer.FindOrOpen(str(base))
    attr = layer.GetAttributeAtPath(f"{OBJ}/car_0002.xformOp:translate")
    old = attr.default
    attr.default = Gf.Vec3d(40.0, 20.0, old[2])  # the car stands elsewhere now (no longer on the road)
    layer.Save()
    stale_key = load_opinions(base.parent / INDEX_FILE, layers_key([base]))
    assert stale_key is None  # the key is the layers' bytes
    with WorldEditor(large) as editor:
        index = editor._state._object_index()
        assert tuple(index.centers[index.names.index("car_0002")]) == (40.0, 20.0)
        # car_0001 moved onto car_0002's new place collides with it: found through the index
        with pytest.raises(EditRefused, match="car_0002"):
            editor.move("car_0001", to=(40.0, 20.0))
    # a world this small keeps the stale file (unused); one as large as the threshold rewrites it
    assert load_opinions(base.parent / INDEX_FILE, layers_key([base])) is None
    edits = Sdf.Layer.FindOrOpen(str(large / "layers" / "edits.usda"))
    assert _same(lower_opinions((edits, layer), 3), read_opinions([layer]))
    assert _same(load_opinions(base.parent / INDEX_FILE, layers_key([base])), read_opinions([layer]))


def test_the_file_gives_the_index_the_layers_give_after_edits(large):
    with WorldEditor(large, clock=lambda: "") as editor:
        editor.move("car_0001", by=(0.5, 0.0), force=True)
        editor.delete("person_0001")
        editor.add("car", (30.0, -2.0), force=True)
        editor.replace("car_0002", "car", variant=editor.variants("car")[-1], force=True)
        layers = editor._state.layers
        lower = lower_opinions(layers, 1)
        assert _same(lower, read_opinions(layers[1:]))
        with_file = _index_arrays(editor, lower)
        from_layers = _index_arrays(editor, None)
    assert with_file[0] == from_layers[0] and len(with_file[0]) == 4
    for a, b in zip(with_file[1:], from_layers[1:]):
        assert np.array_equal(a, b)


def test_the_editor_keeps_a_file_only_for_a_large_world(template, tmp_path):
    small = shutil.copytree(template["small"], tmp_path / "small")
    before = sorted(p.name for p in (small / "layers").iterdir())
    with WorldEditor(small) as editor:
        editor.move("car_0001", by=(0.5, 0.0), force=True)
        layers = editor._state.layers
        assert not (small / "layers" / INDEX_FILE).exists()  # 3 objects < 1,000
        lower_opinions(layers, 1)  # as a large world: the file is written
    after = sorted(p.name for p in (small / "layers").iterdir())
    assert after == sorted([*before, INDEX_FILE, "edits.usda.lock"])
    base = small / BASE_LAYER
    assert load_opinions(small / "layers" / INDEX_FILE, layers_key([base])) is not None


def test_merging_takes_the_stronger_opinion_field_by_field():
    nan = float("nan")
    lower = Opinions(
        ("a", "b"),
        np.array([True, True]),
        np.array([[1.0, 2.0], [3.0, 4.0]]),
        np.array([[1.0, 1.0], [2.0, 2.0]]),
        ("car", "tree"),
        ("suv", None),
        (None, None),
    )
    upper = Opinions(
        ("b", "c"),
        np.array([False, True]),
        np.array([[5.0, 6.0], [7.0, 8.0]]),
        np.array([[nan, nan], [1.0, 1.0]]),
        (None, "person"),
        ("oak", None),
        (False, None),
    )
    merged = merge_opinions(upper, lower)
    assert merged.names == ("b", "c", "a")
    assert merged.defined.tolist() == [True, True, True]
    assert merged.translate.tolist() == [[5.0, 6.0], [7.0, 8.0], [1.0, 2.0]]
    assert merged.scale.tolist() == [[2.0, 2.0], [1.0, 1.0], [1.0, 1.0]]
    assert merged.label == ("tree", "person", "car")
    assert merged.variant == ("oak", None, "suv")
    assert merged.active == (False, None, None)
    empty = Opinions((), np.zeros(0, bool), np.zeros((0, 2)), np.zeros((0, 2)), (), (), ())
    assert merge_opinions(empty, lower) is lower


def test_a_file_of_the_first_format_is_read_again_and_rewritten(large):
    """An index written before the heights, yaws, assets and plainness were kept (format 1) is keyed
    to another format: never read as the current one; the editor's read rewrites it."""
    import io

    from usdworld.authoring.editing import index_file

    base = large / BASE_CRATE_LAYER
    layer = Sdf.Layer.FindOrOpen(str(base))
    file = base.parent / INDEX_FILE
    with np.load(file) as data:
        old = {k: data[k] for k in data.files if k not in ("z_scale_yaw", "assets", "asset_code", "plain")}
    h = __import__("hashlib").sha256(b"usdworld-object-index/1\0")
    h.update(base.name.encode() + b"\0" + __import__("hashlib").sha256(base.read_bytes()).digest())
    old["key"] = np.array(h.hexdigest())
    buf = io.BytesIO()
    np.savez(buf, **old)
    file.write_bytes(buf.getvalue())
    assert index_file.INDEX_FORMAT != "usdworld-object-index/1"
    assert load_opinions(file, layers_key([base])) is None
    edits = Sdf.Layer.FindOrOpen(str(large / "layers" / "edits.usda"))
    assert _same(lower_opinions((edits, layer), 1), read_opinions([layer]))
    kept = load_opinions(file, layers_key([base]))
    assert kept is not None and _same(kept, read_opinions([layer])) and kept.plain.all()


_VARIANTS_OF_A_PLAIN_SPEC = {
    "a child": lambda spec: Sdf.PrimSpec(spec, "Extra", Sdf.SpecifierDef, "Mesh"),
    "a visibility": lambda spec: Sdf.AttributeSpec(spec, "visibility", Sdf.ValueTypeNames.Token),
    "primvars": lambda spec: Sdf.AttributeSpec(
        spec, "primvars:displayColor", Sdf.ValueTypeNames.Color3fArray
    ),
    "a material binding": lambda spec: Sdf.RelationshipSpec(spec, "material:binding"),
    "another op": lambda spec: spec.attributes["xformOpOrder"].__setattr__(
        "default", ["xformOp:translate", "xformOp:rotateZ", "xformOp:scale", "xformOp:rotateX"]
    ),
    "ops reordered": lambda spec: spec.attributes["xformOpOrder"].__setattr__(
        "default", ["xformOp:translate", "xformOp:scale", "xformOp:rotateZ"]
    ),
    "a time-sampled place": lambda spec: spec.layer.SetTimeSample(
        spec.path.AppendProperty("xformOp:translate"), 1.0, Gf.Vec3d(1, 2, 0)
    ),
    "another variant set": lambda spec: spec.variantSelections.__setitem__("look", "worn"),
    "a payload": lambda spec: spec.payloadList.Prepend(Sdf.Payload("other.usda")),
    "instanceable": lambda spec: setattr(spec, "instanceable", True),
    "a kind": lambda spec: setattr(spec, "kind", "component"),
    "an over": lambda spec: setattr(spec, "specifier", Sdf.SpecifierOver),
    "a second reference": lambda spec: spec.referenceList.Append(Sdf.Reference("../assets/tree.usda")),
    "a prim path": lambda spec: spec.referenceList.__setattr__(
        "prependedItems", [Sdf.Reference("../assets/car.usda", "/Car")]
    ),
    "a layer offset": lambda spec: spec.referenceList.__setattr__(
        "prependedItems", [Sdf.Reference("../assets/car.usda", layerOffset=Sdf.LayerOffset(2.0))]
    ),
    "no scale": lambda spec: spec.RemoveProperty(spec.attributes["xformOp:scale"]),
}


@pytest.mark.parametrize("change", sorted(_VARIANTS_OF_A_PLAIN_SPEC))
def test_a_spec_with_anything_the_index_does_not_describe_is_not_plain(template, change):
    """The render composes a plain object from the index alone: anything else on its spec
    (that could change its meshes, place or visibility) makes it not plain, in the file too."""
    from usdworld.authoring.editing.index import plain_asset

    base = Sdf.Layer.FindOrOpen(str(template["large"] / BASE_CRATE_LAYER))
    layer = Sdf.Layer.CreateAnonymous(".usda")
    path = Sdf.Path(f"{OBJ}/car_0001")
    Sdf.CreatePrimInLayer(layer, path.GetParentPath())
    assert Sdf.CopySpec(base, path, layer, path)
    spec = layer.GetPrimAtPath(path)
    assert plain_asset(spec) == base.GetPrimAtPath(path).referenceList.prependedItems[0].assetPath
    assert read_opinions([layer]).plain.tolist() == [True]
    _VARIANTS_OF_A_PLAIN_SPEC[change](spec)
    assert plain_asset(spec) is None
    opinions = read_opinions([layer])
    assert opinions.plain.tolist() == [False] and opinions.asset == (None,)


def test_an_object_in_two_layers_is_not_plain(template):
    base = Sdf.Layer.FindOrOpen(str(template["large"] / BASE_CRATE_LAYER))
    upper = Sdf.Layer.CreateAnonymous(".usda")
    Sdf.CreatePrimInLayer(upper, f"{OBJ}/car_0001")  # an over, as an edit writes
    lower = read_opinions([base])
    merged = merge_opinions(read_opinions([upper]), lower)
    assert lower.plain.all() and merged.names[0] == "car_0001"
    assert merged.plain.tolist() == [False, True, True] and merged.asset[0] is None
    assert not read_opinions([upper, base]).plain[0]
