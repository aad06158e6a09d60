"""Random edit sequences (hypothesis): base untouched, no overlaps unless forced, exact undo."""

from __future__ import annotations

import shutil

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_edit_support import sha256, template

from usdworld.authoring.editing.state import footprints
from usdworld.authoring.edits import WorldEditor
from usdworld.errors import EditRefused
from usdworld.layout.permissible import footprint_overlaps

NAMES = ["car_0001", "car_0002", "person_0001", "car_0003", "person_0002", "tree_0001"]
xs, ys = st.floats(8.0, 60.0), st.floats(-11.0, 11.0)
force = st.sampled_from([False, False, False, True])
ops = st.one_of(
    st.tuples(st.just("move"), st.sampled_from(NAMES), xs, ys, force),
    st.tuples(st.just("rotate"), st.sampled_from(NAMES), st.floats(-360.0, 360.0), force),
    st.tuples(st.just("delete"), st.sampled_from(NAMES)),
    st.tuples(st.just("add"), st.sampled_from(["car", "person", "tree"]), xs, ys, force),
    st.tuples(
        st.just("replace"), st.sampled_from(NAMES), st.sampled_from(["car", "truck", "bus", "rider"]), force
    ),
    st.tuples(st.just("restyle"), st.sampled_from(NAMES), st.sampled_from(["#c03030", "#2a4d8f"])),
    st.tuples(st.just("reset"), st.sampled_from(NAMES), force),
    st.tuples(st.just("undo"), st.integers(1, 3)),
)


def _apply(editor: WorldEditor, op: tuple) -> None:
    kind = op[0]
    if kind == "move":
        editor.move(op[1], to=(op[2], op[3]), force=op[4])
    elif kind == "rotate":
        editor.rotate(op[1], op[2], force=op[3])
    elif kind == "delete":
        editor.delete(op[1])
    elif kind == "add":
        editor.add(op[1], (op[2], op[3]), force=op[4])
    elif kind == "replace":
        variant = "hatchback" if op[2] == "car" else None
        editor.replace(op[1], op[2], variant=variant, force=op[3])
    elif kind == "restyle":
        editor.restyle(op[1], op[2])
    elif kind == "reset":
        editor.reset(op[1], force=op[2])


def _overlaps(editor: WorldEditor) -> list:
    return footprint_overlaps(footprints(editor.objects()))


@settings(
    max_examples=25,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(st.lists(ops, min_size=1, max_size=10))
def test_random_edit_sequences(tmp_path_factory, sequence):
    _, pristine = template(tmp_path_factory)
    folder = tmp_path_factory.mktemp("prop") / "world"
    shutil.copytree(pristine, folder)
    edits = folder / "layers" / "edits.usda"
    hashes = {p: sha256(p) for p in (folder / "world.usda", folder / "layers" / "base.usda")}
    with WorldEditor(folder) as editor:
        assert _overlaps(editor) == []
        states = [(edits.read_text(), editor.objects())]  # state after each recorded step
        for op in sequence:
            before = edits.read_text()
            try:
                if op[0] == "undo":
                    editor.undo(op[1])
                    del states[len(states) - op[1] :]
                    text, objects = states[-1]
                    assert edits.read_text() == text  # byte-identical to k steps ago
                    assert editor.objects() == objects
                    continue
                _apply(editor, op)
            except EditRefused:
                assert edits.read_text() == before  # refused: nothing written
                continue
            states.append((edits.read_text(), editor.objects()))
            assert len(editor.history()) == len(states) - 1
        for path, digest in hashes.items():
            assert sha256(path) == digest
        if not any(h.forced for h in editor.history()):
            assert _overlaps(editor) == []
        cached = editor.objects()
    with WorldEditor(folder) as reread:  # the editor's cache matches a fresh read
        assert reread.objects() == cached
        assert np.all([o.active or o.status == "deleted" for o in cached])
