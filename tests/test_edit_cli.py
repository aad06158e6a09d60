"""``usdworld edit``: exact exit codes and messages."""

from __future__ import annotations

import json

import pytest
from test_edit_support import fresh_world, sha256

from usdworld.cli.main import main
from usdworld.resources import data_dir

SURFACE_RULES = data_dir() / "surface_rules.json"
REFUSED_SIDEWALK = (
    f"error: move car_0001 refused: surface: car may stand on road, not sidewalk (rules: {SURFACE_RULES}); "
    "nothing was written (--force applies it anyway)\n"
)


@pytest.fixture()
def world(tmp_path_factory, tmp_path):
    return fresh_world(tmp_path_factory, tmp_path / "world")


def run(capsys, *args):
    code = main(["edit", *[str(a) for a in args]])
    out, err = capsys.readouterr()
    return code, out, err


def test_list(world, capsys):
    code, out, err = run(capsys, world, "list")
    lines = out.splitlines()
    assert code == 0 and err == ""
    assert lines[0].split() == [
        "name",
        "class",
        "variant",
        "x",
        "m",
        "y",
        "m",
        "yaw",
        "deg",
        "scale",
        "surface",
        "status",
    ]
    assert [line.split()[0] for line in lines[1:-1]] == ["car_0001", "car_0002", "person_0001"]
    assert [line.split()[-2:] for line in lines[1:-1]] == [
        ["road", "base"],
        ["road", "base"],
        ["sidewalk", "base"],
    ]
    assert lines[-1] == "3 object(s), 0 deleted"
    code, out, _ = run(capsys, world.parent, "list")  # the folder works too
    assert code == 0 and out.splitlines()[-1] == "3 object(s), 0 deleted"


def test_move_by_negative_and_to(world, capsys):
    assert run(capsys, world, "move", "car_0001", "--to", "30,0") == (
        0,
        "moved car_0001 to (30.00, 0.00) on road [step 1]\n",
        "",
    )
    assert run(capsys, world, "move", "/World/Objects/car_0001", "--by", "-2,-0.5") == (
        0,
        "moved car_0001 to (28.00, -0.50) on road [step 2]\n",
        "",
    )


def test_refused_edit_exits_2_and_writes_nothing(world, capsys):
    before = sha256(world.parent / "layers/edits.usda")
    assert run(capsys, world, "move", "car_0001", "--to", "30,7.5") == (2, "", REFUSED_SIDEWALK)
    assert sha256(world.parent / "layers/edits.usda") == before


def test_force_records_and_history_shows_it(world, capsys):
    code, out, err = run(capsys, world, "move", "car_0001", "--to", "30,7.5", "--force")
    assert (code, err) == (0, "")
    assert out == (
        f"moved car_0001 to (30.00, 7.50) on sidewalk (forced: surface: car may stand on road, not sidewalk "
        f"(rules: {SURFACE_RULES})) [step 1]\n"
    )
    code, out, _ = run(capsys, world, "history")
    first, last = out.splitlines()
    assert code == 0 and last == "1 edit(s)"
    assert first.split()[0] == "1" and first.split()[2:5] == ["move", "car_0001", "to=[30.0,"]
    assert first.endswith(f"FORCED (surface: car may stand on road, not sidewalk (rules: {SURFACE_RULES}))")


def test_every_operation(world, capsys):
    assert run(capsys, world, "rotate", "car_0001", "--yaw-deg", "-90") == (
        0,
        "rotated car_0001 to -90.0 deg [step 1]\n",
        "",
    )
    code, out, _ = run(capsys, world, "add", "tree", "--at", "30,7.5", "--variant", "conifer")
    assert (
        code == 0
        and out == "added tree_0001 (tree conifer, scale 1.00) at (30.00, 7.50) on sidewalk [step 2]\n"
    )
    code, out, _ = run(capsys, world, "replace", "car_0002", "--with", "truck")
    assert (
        code == 0
        and out.startswith("replaced car_0002 (car hatchback) with truck box_truck, scale ")
        and out.endswith(" [step 3]\n")
    )
    assert run(capsys, world, "restyle", "car_0001", "--color", "#C03030") == (
        0,
        "restyled car_0001 #c03030 (paint_red) [step 4]\n",
        "",
    )
    assert run(capsys, world, "delete", "person_0001") == (0, "deleted person_0001 (inactive) [step 5]\n", "")
    code, out, _ = run(capsys, world, "list")
    assert "person_0001" in out and out.splitlines()[-1] == "4 object(s), 1 deleted"
    rows = [line.split() for line in out.splitlines()[1:-1]]  # sorted by class, then name
    assert [(r[0], r[1], r[-1]) for r in rows] == [
        ("car_0001", "car", "#c03030"),
        ("person_0001", "person", "deleted"),
        ("tree_0001", "tree", "added"),
        ("car_0002", "truck", "edited"),
    ]
    assert run(capsys, world, "undo", "2") == (
        0,
        "undid step 5: delete person_0001\nundid step 4: restyle car_0001\n",
        "",
    )
    assert run(capsys, world, "reset", "car_0002") == (0, "reset car_0002 to the base [step 4]\n", "")
    assert run(capsys, world, "check") == (
        0,
        f"{world.parent / 'layers/edits.usda'}: every edit targets an existing prim\n",
        "",
    )


def test_check_reports_orphans_and_exits_1(world, capsys):
    from pxr import Sdf

    layer = Sdf.Layer.FindOrOpen(str(world.parent / "layers/edits.usda"))
    Sdf.CreatePrimInLayer(layer, "/World/Objects/car_0042")
    layer.Save()
    code, out, err = run(capsys, world, "check")
    assert code == 1
    assert (
        out == "orphaned edit: /World/Objects/car_0042 (steps none recorded): no such prim in the world; "
        "`reset car_0042` drops it\n"
    )
    assert (
        err == f"error: 1 edit(s) in {world.parent / 'layers/edits.usda'} target prims that no longer exist\n"
    )


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["move", "car_0001", "--to", "1"], "error: --to: expected two numbers 'x,y' in metres, got '1'\n"),
        (["move", "car_0001"], "error: move: give exactly one of --to x,y or --by dx,dy\n"),
        (["rotate", "car_0099", "--yaw-deg", "3"], None),
        (["add", "unicorn", "--at", "1,2"], None),
        (
            ["restyle", "car_0001", "--color", "red"],
            "error: --color: expected a hex colour like '#c03030', got 'red'\n",
        ),
        (["undo", "3"], None),
        (["replace", "person_0001", "--with", "car"], None),
    ],
)
def test_bad_input_exits_2(world, capsys, args, message):
    code, out, err = run(capsys, world, *args)
    assert code == 2 and out == ""
    assert err.startswith("error: ") and err.count("\n") == 1
    if message is not None:
        assert err == message
    if args[0] == "undo":
        assert err == f"error: undo 3: only 0 edit(s) recorded in {world.parent / 'layers/edits.usda'}\n"
    if args[0] == "rotate":
        assert (
            err == f"error: no object 'car_0099' in {world}; `usdworld edit {world} list` shows the names\n"
        )


def test_missing_world_exits_2(tmp_path, capsys):
    missing = tmp_path / "nope" / "world.usda"
    assert run(capsys, missing, "list") == (
        2,
        "",
        f"error: {missing}: no such world; pass the world's root layer (e.g. OUT/world.usda) or its folder\n",
    )


def test_user_surface_rules_by_option_and_env(world, capsys, tmp_path, monkeypatch):
    mine = tmp_path / "rules.json"
    mine.write_text(json.dumps({"car": ["road", "sidewalk"]}))
    code, out, _ = run(capsys, world, "move", "car_0001", "--to", "30,7.5", "--surface-rules", mine)
    assert code == 0 and out == "moved car_0001 to (30.00, 7.50) on sidewalk [step 1]\n"
    strict = tmp_path / "strict.json"
    strict.write_text(json.dumps({"car": ["other"]}))
    monkeypatch.setenv("USDWORLD_SURFACE_RULES", str(strict))
    code, _, err = run(capsys, world, "move", "car_0001", "--to", "31,7.5")
    assert code == 2 and err == (
        f"error: move car_0001 refused: surface: car may stand on other, not sidewalk (rules: {strict}); "
        "nothing was written (--force applies it anyway)\n"
    )


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("rotate", "car_0001", "--yaw-deg", "nan"), "--yaw-deg: must be finite, got nan"),
        (("move", "car_0001", "--to", "inf,0"), "move: --to must be finite, got (inf, 0.0)"),
        (("move", "car_0001"), "move: give exactly one of --to x,y or --by dx,dy"),
        (
            ("restyle", "car_0001", "--color", "red"),
            "--color: expected a hex colour like '#c03030', got 'red'",
        ),
        (
            ("add", "car", "--at", "40,0", "--variant", "limo"),
            "--variant: car has no variant 'limo'; available: hatchback, sedan, suv",
        ),
        (
            ("replace", "car_0001", "--with", "car"),
            "replace car_0001: it is already a car; pass --variant (one of hatchback, sedan, suv)",
        ),
        (("undo", "0"), "undo: N must be >= 1, got 0"),
        (("delete", "car 1"), "'car 1': not an object name; use e.g. car_0003 or /World/Objects/car_0003"),
    ],
)
def test_refusals_are_worded_for_the_command_line(world, capsys, args, message):
    before = sha256(world.parent / "layers/edits.usda")
    assert run(capsys, world, *args) == (2, "", f"error: {message}\n")
    assert sha256(world.parent / "layers/edits.usda") == before


def test_unknown_and_deleted_objects_name_the_commands_that_help(world, capsys):
    edits = world.parent / "layers" / "edits.usda"
    assert run(capsys, world, "reset", "car_0001") == (
        2,
        "",
        f"error: car_0001 has no edits to reset in {edits}\n",
    )
    assert run(capsys, world.parent, "delete", "car_0099") == (
        2,
        "",
        f"error: no object 'car_0099' in {world}; `usdworld edit {world} list` shows the names\n",
    )
    assert run(capsys, world, "delete", "car_0001")[0] == 0
    assert run(capsys, world, "move", "car_0001", "--by", "1,0") == (
        2,
        "",
        "error: car_0001 is deleted; `reset car_0001` or `undo` brings it back\n",
    )
