"""WorldEditor on a built world: what each edit authors, refusals, history, undo, rebuilds."""

from __future__ import annotations

import os

import pytest
from pxr import Gf, Pcp, Sdf, Usd, UsdGeom, UsdShade
from test_edit_support import base_x, build_world, fresh_world, sha256, template

from usdworld.authoring.edits import WorldEditor, parse_color
from usdworld.authoring.validate import errors_only, validate_file
from usdworld.errors import EditRefused, InputError

OBJ = "/World/Objects"


@pytest.fixture()
def world(tmp_path_factory, tmp_path):
    return fresh_world(tmp_path_factory, tmp_path / "world")


@pytest.fixture()
def editor(world):
    with WorldEditor(world) as e:
        yield e


def _fresh_stage(world):
    """The composed world as a new reader sees it (no in-memory layers shared)."""
    for p in ("layers/edits.usda", "layers/base.usda", "world.usda"):
        layer = Sdf.Layer.Find(str(world.parent / p))
        if layer is not None:
            layer.Reload(force=True)
    return Usd.Stage.Open(str(world))


def _edits_text(world):
    return (world.parent / "layers" / "edits.usda").read_text()


def test_edits_go_to_the_edits_layer_only(world, editor):
    base, root = sha256(world.parent / "layers/base.usda"), sha256(world)
    editor.move("car_0001", by=(2.0, 0.0))
    editor.rotate("car_0002", 10.0)
    editor.add("tree", (30.0, 7.0))
    editor.replace("car_0001", "car", variant="suv")
    editor.restyle("car_0002", "#c03030")
    editor.delete("person_0001")
    assert sha256(world.parent / "layers/base.usda") == base and sha256(world) == root
    stage = _fresh_stage(world)
    car = stage.GetPrimAtPath(f"{OBJ}/car_0001")
    assert tuple(car.GetAttribute("xformOp:translate").Get())[0] == pytest.approx(
        base_x(world, "car_0001") + 2.0, abs=0.01
    )
    assert car.GetVariantSets().GetVariantSelection("model") == "suv"


def test_move_authors_translate_and_follows_the_ground(world, editor):
    result = editor.move("/World/Objects/person_0001", to=(15.0, -7.0))
    assert result.message == "moved person_0001 to (15.00, -7.00) on sidewalk" and result.step == 1
    layer = Sdf.Layer.FindOrOpen(str(world.parent / "layers/edits.usda"))
    spec = layer.GetPrimAtPath(f"{OBJ}/person_0001")
    assert spec.specifier == Sdf.SpecifierOver
    assert tuple(spec.attributes["xformOp:translate"].default) == pytest.approx((15.0, -7.0, 0.15))
    editor.move("person_0001", to=(15.0, 0.0))  # onto the road: z drops to the road's top
    assert editor.objects()[2].position_world == pytest.approx((15.0, 0.0, 0.0))


def test_refused_move_names_rule_and_object_and_writes_nothing(world, editor):
    before = _edits_text(world)
    with pytest.raises(EditRefused) as err:
        editor.move("car_0001", to=(16.5, -2.8))
    msg = str(err.value)
    assert msg.startswith("move car_0001 refused: fit: overlaps car_0002 by ")
    assert msg.endswith("; nothing was written")  # neutral: no CLI flag
    assert (err.value.reason, err.value.op, err.value.subject) == ("not_permissible", "move", "car_0001")
    (fit,) = err.value.violations
    assert (fit.rule, fit.other) == ("fit", "car_0002") and fit.amount_m > 0.0
    assert fit.message == f"overlaps car_0002 by {fit.amount_m:.2f} m"
    assert _edits_text(world) == before
    with pytest.raises(EditRefused, match=r"surface: car may stand on road, not sidewalk"):
        editor.move("car_0001", to=(30.0, 7.0))
    with pytest.raises(EditRefused, match=r"extent: footprint reaches .* outside the ground extent"):
        editor.move("car_0001", to=(300.0, 0.0))
    assert _edits_text(world) == before and editor.history() == []


def test_force_applies_and_records(world, editor):
    result = editor.move("car_0001", to=(30.0, 7.0), force=True)
    assert result.forced and result.violations == (
        f"surface: car may stand on road, not sidewalk (rules: {editor.surface_rules.source})",
    )
    assert "(forced: surface: car may stand on road" in result.message
    (entry,) = editor.history()
    assert entry.forced and entry.op == "move" and entry.args == {"name": "car_0001", "to": [30.0, 7.0]}
    assert entry.violations == result.violations and entry.time.endswith("+00:00")


def test_rotate_checks_fit_of_the_rotated_footprint(world, editor):
    editor.move("car_0002", to=(22.3, -1.3))  # parallel to car_0001, 1.3 m gap... rotate would hit it
    with pytest.raises(EditRefused, match=r"rotate car_0002 refused: fit: overlaps car_0001 by"):
        editor.rotate("car_0002", 90.0)
    assert editor.rotate("car_0002", 180.0).message == "rotated car_0002 to 180.0 deg"
    assert editor.rotate("car_0002", 540.0).message == "rotated car_0002 to 180.0 deg"


def test_delete_deactivates_but_keeps_the_prim(world, editor):
    editor.delete("person_0001")
    stage = _fresh_stage(world)
    prim = stage.GetPrimAtPath(f"{OBJ}/person_0001")
    assert prim and prim.IsDefined() and not prim.IsActive()
    assert 'over "person_0001" (\n            active = false' in _edits_text(world)
    with pytest.raises(
        EditRefused, match="person_0001 is deleted; a reset of person_0001 or an undo brings it back"
    ) as err:
        editor.move("person_0001", by=(1.0, 0.0))
    assert err.value.reason == "deleted_object" and err.value.subject == "person_0001"
    # a deleted object no longer blocks others
    assert editor.add("person", (12.1, -6.6)).name == "person_0002"


def test_add_defines_a_referenced_prim_with_provenance(world, editor):
    result = editor.add("car", (40.0, -1.5))
    assert result.name == "car_0003"
    assert result.message.startswith("added car_0003 (car hatchback, scale 1.0") and result.message.endswith(
        "at (40.00, -1.50) on road"
    )
    layer = Sdf.Layer.FindOrOpen(str(world.parent / "layers/edits.usda"))
    spec = layer.GetPrimAtPath(f"{OBJ}/car_0003")
    assert spec.specifier == Sdf.SpecifierDef and spec.typeName == "Xform"
    assert list(spec.referenceList.explicitItems) == [Sdf.Reference("../assets/car.usda")]
    stage = _fresh_stage(world)
    prim = stage.GetPrimAtPath(f"{OBJ}/car_0003")
    assert prim.GetAttribute("usdworld:depthMethod").Get() == "user"
    assert prim.GetAttribute("usdworld:sourceImage").Get() == ""
    assert prim.GetAttribute("semantics:labels:class").Get() == ["car"]
    assert "UsdWorldProvenanceAPI" in prim.GetAppliedSchemas()
    assert [o.status for o in editor.objects()][-1] == "added"
    # a neighbour-sized car along the road, and the numbering continues
    obj = {o.name: o for o in editor.objects()}
    assert obj["car_0003"].scale == pytest.approx(
        (obj["car_0001"].scale + obj["car_0002"].scale) / 2, abs=1e-6
    )
    assert obj["car_0003"].yaw_deg == pytest.approx(obj["car_0001"].yaw_deg)  # along the nearest car
    assert editor.add("car", (50.0, -1.5)).name == "car_0004"


def test_add_copies_a_missing_asset_into_the_world(world, editor):
    assert not (world.parent / "assets/tree.usda").exists()
    editor.add("tree", (30.0, 7.5), variant="conifer")
    assert (world.parent / "assets/tree.usda").is_file() and (
        world.parent / "assets/tree.geom.usdc"
    ).is_file()
    stage = _fresh_stage(world)
    prim = stage.GetPrimAtPath(f"{OBJ}/tree_0001")
    assert prim.GetVariantSets().GetVariantSelection("model") == "conifer"
    assert any(c.IsA(UsdGeom.Mesh) for c in Usd.PrimRange(prim))


def test_add_refusals(world, editor):
    with pytest.raises(
        EditRefused, match=r"add tree_0001 refused: surface: tree may stand on sidewalk or other, not road"
    ):
        editor.add("tree", (30.0, 0.0))
    person = next(o for o in editor.objects() if o.name == "person_0001")
    x, y = (float(v) for v in person.position_world[:2])
    with pytest.raises(EditRefused, match=r"add person_0002 refused: fit: overlaps person_0001 by"):
        editor.add("person", (x + 0.1, y - 0.1))
    with pytest.raises(EditRefused, match="unknown class 'unicorn'; known classes: ") as err:
        editor.add("unicorn", (30.0, 0.0))
    assert err.value.reason == "unknown_class" and "car" in err.value.choices
    with pytest.raises(
        EditRefused, match="^car has no variant 'limo'; available: hatchback, sedan, suv$"
    ) as err:
        editor.add("car", (40.0, 0.0), variant="limo")
    assert (err.value.reason, err.value.field, err.value.value) == ("unknown_variant", "variant", "limo")
    assert err.value.choices == ("hatchback", "sedan", "suv")
    assert editor.history() == []


def test_replace_with_another_class_swaps_the_reference_list(world, editor):
    result = editor.replace("car_0002", "bus")
    assert result.message.startswith("replaced car_0002 (car hatchback) with bus city_bus, scale ")
    stage = _fresh_stage(world)
    prim = stage.GetPrimAtPath(f"{OBJ}/car_0002")
    arcs = [  # reference arcs only: the base layer's own variant bodies (photo colours) are a variant arc
        n.layerStack.identifier.rootLayer.identifier
        for n in prim.GetPrimIndex().rootNode.children
        if n.arcType == Pcp.ArcTypeReference
    ]
    assert len(arcs) == 1 and arcs[0].endswith("assets/bus.usda")  # not car + bus
    assert prim.GetAttribute("semantics:labels:class").Get() == ["bus"]
    layer = Sdf.Layer.FindOrOpen(str(world.parent / "layers/edits.usda"))
    spec = layer.GetPrimAtPath(f"{OBJ}/car_0002")
    assert spec.referenceList.isExplicit


def test_replace_refusals_class_rule_and_same_class(world, editor):
    with pytest.raises(
        EditRefused,
        match=r"replace person_0001 refused: class: person may be replaced by person, rider, not car",
    ):
        editor.replace("person_0001", "car")
    with pytest.raises(
        EditRefused,
        match=r"replace car_0001: it is already a car; name a variant \(one of hatchback, sedan, suv\)",
    ):
        editor.replace("car_0001", "car")
    r = editor.replace("person_0001", "car", force=True)
    assert r.forced and any(v.startswith("class: ") for v in r.violations)


def test_restyle_recolours_paint_material_and_display_color(world, editor):
    editor.restyle("car_0001", "#c03030")
    stage = _fresh_stage(world)
    car = stage.GetPrimAtPath(f"{OBJ}/car_0001")
    linear, _ = parse_color("#c03030")
    mat = UsdShade.Material(stage.GetPrimAtPath(f"{OBJ}/car_0001/Looks/paint_red"))
    shader, _, _ = mat.ComputeSurfaceSource()
    assert tuple(shader.GetInput("diffuseColor").Get()) == pytest.approx(linear, abs=1e-6)
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath(f"{OBJ}/car_0001/Geom/paint_red"))
    assert tuple(mesh.GetDisplayColorAttr().Get()[0]) == pytest.approx(linear, abs=1e-6)
    glass = UsdShade.Material(stage.GetPrimAtPath(f"{OBJ}/car_0001/Looks/glass")).ComputeSurfaceSource()[0]
    assert tuple(glass.GetInput("diffuseColor").Get()) != pytest.approx(linear, abs=1e-3)
    assert car.GetCustomDataByKey("usdworld:restyleColor") == "#c03030"
    # a variant switch re-applies the colour to the new variant's paint
    editor.replace("car_0001", "car", variant="suv")
    stage = _fresh_stage(world)
    blue = UsdShade.Material(stage.GetPrimAtPath(f"{OBJ}/car_0001/Looks/paint_blue")).ComputeSurfaceSource()[
        0
    ]
    assert tuple(blue.GetInput("diffuseColor").Get()) == pytest.approx(linear, abs=1e-6)
    with pytest.raises(EditRefused, match="^color: expected a hex colour like '#c03030', got 'red'$"):
        editor.restyle("car_0001", "red")


def test_undo_restores_the_exact_previous_layer(world, editor):
    texts = [_edits_text(world)]
    editor.move("car_0001", by=(1.0, 0.5))
    texts.append(_edits_text(world))
    editor.add("person", (20.0, -7.0))
    texts.append(_edits_text(world))
    editor.restyle("car_0001", "#2a4d8f")
    texts.append(_edits_text(world))
    editor.reset("car_0001")
    texts.append(_edits_text(world))
    editor.delete("person_0002")
    texts.append(_edits_text(world))
    for k in range(1, len(texts)):
        (undone,) = editor.undo()
        assert _edits_text(world) == texts[-1 - k], f"after undoing step {undone.step}"
    assert texts[0] == _edits_text(world)
    with pytest.raises(EditRefused, match=r"^undo 1: only 0 edit\(s\) recorded$"):
        editor.undo()


def test_undo_n_and_history(world, editor):
    editor.move("car_0001", by=(1.0, 0.0))
    editor.rotate("car_0001", 5.0)
    editor.delete("person_0001")
    assert [h.op for h in editor.history()] == ["move", "rotate", "delete"]
    undone = editor.undo(2)
    assert [u.op for u in undone] == ["delete", "rotate"]
    assert [h.step for h in editor.history()] == [1]
    assert _fresh_stage(world).GetPrimAtPath(f"{OBJ}/person_0001").IsActive()


def test_reset_drops_edits_and_checks_fit(world, editor):
    editor.move("car_0002", to=(30.0, -2.8))
    editor.move("car_0001", to=(15.8, -2.8))  # into car_0002's old spot
    with pytest.raises(EditRefused, match=r"reset car_0002 refused: fit: overlaps car_0001 by"):
        editor.reset("car_0002")
    editor.reset("car_0001")
    assert [o.status for o in editor.objects()][:2] == ["base", "edited"]
    editor.reset("car_0002")
    with pytest.raises(EditRefused, match="^car_0002 has no edits to reset$"):
        editor.reset("car_0002")
    added = editor.add("car", (40.0, -1.5)).name
    editor.reset(added)  # an added object disappears
    assert added not in {o.name for o in editor.objects()}


def test_rebuild_keeps_edits_and_check_reports_orphans(tmp_path_factory, world):
    frame, _ = template(tmp_path_factory)
    with WorldEditor(world) as editor:
        editor.move("car_0001", by=(1.0, 0.0))
        editor.delete("person_0001")
        editor.add("tree", (30.0, 7.5))
    edits_before = _edits_text(world)
    build_world(frame, world.parent)
    assert _edits_text(world) == edits_before
    stage = _fresh_stage(world)
    assert not stage.GetPrimAtPath(f"{OBJ}/person_0001").IsActive()
    assert stage.GetPrimAtPath(f"{OBJ}/tree_0001").IsDefined()
    with WorldEditor(world) as editor:
        assert editor.check() == []
        assert [o.position_world[0] for o in editor.objects() if o.name == "car_0001"][0] == pytest.approx(
            base_x(world, "car_0001") + 1.0, abs=0.01
        )
        # hand a stale opinion to the layer: a car the base no longer has
        layer = Sdf.Layer.Find(str(editor.edits_path))
        spec = Sdf.CreatePrimInLayer(layer, f"{OBJ}/car_0042")
        Sdf.AttributeSpec(spec, "xformOp:translate", Sdf.ValueTypeNames.Double3).default = (1, 2, 0)
        layer.Save()
    with WorldEditor(world) as editor:
        (orphan,) = editor.check()
        assert orphan.path == f"{OBJ}/car_0042" and orphan.steps == ()
        editor.reset("car_0042")
        assert editor.check() == []


def test_edited_world_validates_with_no_errors(world, editor):
    editor.move("car_0001", by=(1.0, 0.0))
    editor.add("tree", (30.0, 7.5))
    editor.add("person", (20.0, -7.0))
    editor.replace("car_0002", "truck")
    editor.restyle("car_0001", "#c03030")
    editor.delete("person_0001")
    assert errors_only(validate_file(world)) == []
    for asset in sorted((world.parent / "assets").glob("*.usda")):
        assert errors_only(validate_file(asset, omni=False)) == []


def test_failed_save_leaves_layer_and_memory_unchanged(world, editor, monkeypatch):
    editor.move("car_0001", by=(1.0, 0.0))
    before = _edits_text(world)

    def crash(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", crash)
    with pytest.raises(
        Exception, match="cannot save the edits .No space left on device.; nothing was changed"
    ):
        editor.move("car_0001", by=(1.0, 0.0))
    monkeypatch.undo()
    assert _edits_text(world) == before
    assert not list((world.parent / "layers").glob(".edits.usda.*.tmp"))
    assert len(editor.history()) == 1  # the in-memory layer was rolled back too
    assert editor.move("car_0001", by=(1.0, 0.0)).step == 2


def test_names_and_paths(world, editor):
    with pytest.raises(EditRefused, match="^no object 'car_0099' in this world$") as err:
        editor.delete("car_0099")
    assert (err.value.reason, err.value.op, err.value.subject) == ("unknown_object", "delete", "car_0099")
    with pytest.raises(EditRefused, match="not an object path"):
        editor.delete("/World/Ground/Road")
    with pytest.raises(EditRefused, match="not an object name"):
        editor.delete("car 1")
    with pytest.raises(InputError, match="no such world"):
        WorldEditor(world.parent / "missing.usda")


def test_check_reports_restyle_opinions_orphaned_by_a_new_base_variant(world):
    with WorldEditor(world) as editor:
        editor.restyle("car_0001", "#c03030")
    base = Sdf.Layer.FindOrOpen(str(world.parent / "layers/base.usda"))  # a rebuild that chose another model
    base.GetPrimAtPath(f"{OBJ}/car_0001").variantSelections["model"] = "suv"
    base.Save()
    with WorldEditor(world) as editor:
        orphans = editor.check()
        assert [(o.path, o.steps, o.object_name) for o in orphans] == [
            (f"{OBJ}/car_0001/Looks/paint_red", (1,), "car_0001"),
            (f"{OBJ}/car_0001/Geom/paint_red", (1,), "car_0001"),
        ]
        editor.restyle("car_0001", "#c03030")  # restyling again re-targets the new variant's paint
        assert editor.check() == []


def test_trees_are_checked_by_their_trunk_as_the_build_places_them(world, editor):
    person = next(o for o in editor.objects() if o.name == "person_0001")
    x, y = person.position_world[:2]
    editor.add("tree", (x + 1.2, y), variant="deciduous")  # its crown spreads over the person
    tree = next(o for o in editor.objects() if o.class_name == "tree")
    assert tree.size_lw[1] > 2 * 1.2 > tree.footprint_lw[1]
    editor.move("person_0001", to=(x + 0.3, y))  # still under the crown, clear of the trunk
    with pytest.raises(EditRefused, match="tree_0001"):
        editor.move("person_0001", to=(x + 1.2, y))  # into the trunk


def test_a_stretched_footprint_is_read_per_axis_and_kept_by_edits(world):
    # The build stretches a facade's footprint (its unseen depth): the editor's rules must
    # see the footprint per axis, the height's scale as the object's, and keep the stretch.
    base = Sdf.Layer.FindOrOpen(str(world.parent / "layers/base.usda"))
    base.GetAttributeAtPath(f"{OBJ}/car_0001.xformOp:scale").default = Gf.Vec3f(2.0, 1.5, 1.0)
    base.Save()
    with WorldEditor(world) as editor:
        car = next(o for o in editor.objects() if o.name == "car_0001")
        length, width = editor.size("car", car.variant)
        assert car.scale == pytest.approx(1.0)
        assert car.size_lw == pytest.approx((2.0 * length, 1.5 * width))
        assert car.footprint_lw == pytest.approx(car.size_lw)
        editor.move("car_0001", by=(0.5, 0.0), force=True)
    stage = _fresh_stage(world)
    scale = stage.GetPrimAtPath(f"{OBJ}/car_0001").GetAttribute("xformOp:scale").Get()
    assert tuple(scale) == pytest.approx((2.0, 1.5, 1.0))
