"""The editor composes only what an edit needs: the object, the objects its footprint could touch, the ground."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Sdf
from test_edit_support import fresh_world

from usdworld.authoring.editing.index import read_index
from usdworld.authoring.edits import WorldEditor
from usdworld.errors import EditRefused

OBJ = "/World/Objects"


@pytest.fixture()
def world(tmp_path_factory, tmp_path):
    return fresh_world(tmp_path_factory, tmp_path / "world")


def _composed_objects(editor: WorldEditor) -> list[str]:
    """Names of the objects the editor's stage has composed (without widening its mask)."""
    scope = editor._stage.GetPrimAtPath(OBJ)
    return [] if not scope else [p.GetName() for p in scope.GetAllChildren()]


def test_a_move_composes_only_the_object_and_its_possible_neighbours(world):
    with WorldEditor(world) as editor:
        assert _composed_objects(editor) == []
        with pytest.raises(EditRefused) as masked:
            editor.move("car_0001", to=(16.5, -2.8))  # onto car_0002
        assert _composed_objects(editor) == ["car_0001", "car_0002"]
    with WorldEditor(world) as editor:
        editor.stage  # noqa: B018  (composes the whole world: the reader works as before)
        with pytest.raises(EditRefused) as whole:
            editor.move("car_0001", to=(16.5, -2.8))
    assert str(masked.value) == str(whole.value)
    assert masked.value.violations == whole.value.violations
    with WorldEditor(world) as editor:
        editor.rotate("car_0002", 30.0)
        assert _composed_objects(editor) == ["car_0002"]  # the others stand too far to touch it


def test_the_ground_extent_is_the_same_masked_or_whole(world):
    with WorldEditor(world) as editor:
        masked = editor.ground().extent
        assert _composed_objects(editor) == []
    with WorldEditor(world) as editor:
        editor.objects()
        whole = editor.ground().extent
    assert np.array_equal(masked, whole)


def test_objects_without_their_opinions_in_the_layers_are_composed_whole(world):
    base = Sdf.Layer.FindOrOpen(str(world.parent / "layers/base.usda"))
    spec = base.GetPrimAtPath(f"{OBJ}/person_0001")
    spec.RemoveProperty(spec.attributes["semantics:labels:class"])
    base.Save()
    with WorldEditor(world) as editor:
        layers = editor._state.layers
        assert read_index(layers, editor.size, editor.size, ()) is None
        result = editor.move("car_0001", by=(1.0, 0.0))
        assert result.step == 1 and "person_0001" in _composed_objects(editor)


def test_index_finds_what_a_footprint_could_touch(world):
    with WorldEditor(world) as editor:
        index = read_index(editor._state.layers, editor.size, editor.size, editor._ed.libraries)
        assert index is not None and set(index.names) == {"car_0001", "car_0002", "person_0001"}
        car2 = index.centers[index.names.index("car_0002")]
        assert index.near(car2, 0.1) == ["car_0002"]
        assert set(index.near(car2, 100.0)) == set(index.names)
        editor.delete("car_0002")
        index = read_index(editor._state.layers, editor.size, editor.size, editor._ed.libraries)
        assert index.near(car2, 0.1) == []  # deleted objects touch nothing
