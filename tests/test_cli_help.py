"""``usdworld ... --help`` and ``-q``: choices listed, flags as flags, edit sub-command help,
quiet edits and exports, sorted tables."""

from __future__ import annotations

import io
import json
import re

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from test_edit_support import fresh_world

from usdworld.cli.choices import DepthBackendName, ExportFormat, SegmentBackendName, Traffic
from usdworld.cli.main import COMMANDS, main


def _run(capsys, *args: str) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def test_choices_mirror_the_domain_tables() -> None:
    from usdworld.export import FORMATS
    from usdworld.layout.heading import TRAFFIC_SIDES
    from usdworld.perception.depth import BACKEND_NAMES
    from usdworld.perception.segment import BACKEND_NAMES as SEGMENT_BACKEND_NAMES

    assert [c.value for c in DepthBackendName] == list(BACKEND_NAMES)
    assert [c.value for c in SegmentBackendName] == list(SEGMENT_BACKEND_NAMES)
    assert [c.value for c in ExportFormat] == list(FORMATS)
    assert [c.value for c in Traffic] == list(TRAFFIC_SIDES)


@pytest.mark.parametrize(
    ("command", "expected"),
    [
        (["build"], ["--depth <ground|monodepth|monodepth2|hf|file>", "--traffic <right|left>", "--segment <none|hf>"]),
        (["segment"], ["--segment-model <path>", "--detections <path>"]),
        (["depth"], ["--depth <ground|monodepth|monodepth2|hf|file>"]),
        (["export"], ["-f, --format <usdz|usdc|usda-flat|glb>"]),
        (["batch"], ["--layout <cityscapes|kitti|manifest|views|nuscenes>"]),
    ],
)
def test_help_lists_the_choices(capsys, command, expected) -> None:
    code, out, _ = _run(capsys, *command, "--help")
    assert code == 0
    for text in expected:
        assert text in out, out


def test_no_help_page_shows_a_bool_or_a_free_text_choice(capsys) -> None:
    pages = [[name] for name in COMMANDS]
    pages += [["edit", sub] for sub in ("list", "move", "rotate", "delete", "add", "replace", "restyle")]
    pages += [["edit", sub] for sub in ("undo", "history", "reset", "check")]
    pages += [["assets", "add"], ["assets", "list"]]
    for page in pages:
        code, out, _ = _run(capsys, *page, "--help")
        assert code == 0, page
        assert "<bool>" not in out and "BOOLEAN" not in out, (page, out)
        # A help text that spells out "a, b or c" belongs in the metavar as <a|b|c>.
        assert not re.search(r"<str>\s+\S+: \w+, \w+(, \w+)* or \w+", out), (page, out)


@pytest.mark.parametrize(
    "sub", ["list", "move", "rotate", "delete", "add", "replace", "restyle", "undo", "history", "reset", "check"]
)
def test_edit_subcommand_help_without_a_world(capsys, sub) -> None:
    code, out, err = _run(capsys, "edit", sub, "--help")
    assert code == 0 and err == ""
    assert out.startswith(f"Usage: usdworld edit {{world}} {sub} [OPTIONS]"), out
    assert "Commands:" not in out


def test_edit_subcommand_help_with_a_world(capsys) -> None:
    code, out, _ = _run(capsys, "edit", "some/world.usda", "move", "--help")
    assert code == 0 and out.startswith("Usage: usdworld edit {world} move [OPTIONS]") and "--to" in out


def test_edit_group_help_still_lists_the_subcommands(capsys) -> None:
    code, out, _ = _run(capsys, "edit", "--help")
    assert code == 0 and "Commands:" in out and "move" in out


def test_bad_choice_is_a_usage_error(capsys, tmp_path) -> None:
    code, _, err = _run(capsys, "export", tmp_path, "-f", "obj", "-o", tmp_path / "x.obj")
    assert code == 2 and "'obj' is not one of 'usdz', 'usdc', 'usda-flat', 'glb'" in err


def test_quiet_edits_print_nothing_and_info_gives_degrees(capsys, tmp_path_factory, tmp_path) -> None:
    world = fresh_world(tmp_path_factory, tmp_path / "world")
    code, out, err = _run(capsys, "-q", "edit", world, "rotate", "car_0001", "--yaw-deg", "30")
    assert (code, out, err) == (0, "", "")
    code, out, err = _run(capsys, "-q", "edit", world, "undo")
    assert (code, out, err) == (0, "", "")
    code, out, _ = _run(capsys, "edit", world, "rotate", "car_0001", "--yaw-deg", "30")
    assert code == 0 and out == "rotated car_0001 to 30.0 deg [step 1]\n"
    code, out, _ = _run(capsys, "info", world, "--json")
    pitch = json.loads(out)["camera_pitch_deg"]
    code, out, _ = _run(capsys, "info", world)
    assert isinstance(pitch, float) and f"pitch {pitch:.2f} deg" in out


def test_build_table_is_sorted_by_class_then_name() -> None:
    from usdworld.cli.summary import print_build_summary

    def obj(name: str, cls: str) -> dict:
        return {
            "name": name, "class": cls, "variant": "v", "position_world": [1.0, 2.0, 0.0], "depth_m": 3.0,
            "depth_method": "ground", "scale": 1.0, "yaw_deg": 0.0, "collision_displacement_m": [0.0, 0.0],
        }

    report = {
        "objects": [obj("tree_0001", "tree"), obj("car_0002", "car"), obj("person_0001", "person"), obj("car_0001", "car")],
        "source_image": "x.png",
        "camera": {"height_m": 1.5, "pitch_deg": 1.0, "K": [[700.0, 0, 0], [0, 700.0, 0], [0, 0, 1]], "estimated": []},
        "dlt": {"source": "camera", "rms_px": 0.0},
    }
    text = io.StringIO()
    print_build_summary(report, "w/world.usda", text)
    names = re.findall(r"\b(\w+_\d{4})\b", text.getvalue())
    assert names == ["car_0001", "car_0002", "person_0001", "tree_0001"]


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.sampled_from(["3", "objects", "placed", "from", "x.png", "b" * 30, "c" * 130]), min_size=1, max_size=6),
    st.lists(st.tuples(*[st.sampled_from(["", "a", "car_0001", "residential", "-12.50", "behind_car_0005"])] * 9), max_size=4),
)
def test_build_table_looks_as_richs_table_does(words: list[str], rows: list[tuple[str, ...]]) -> None:
    # The summary's table is drawn without rich (its import and layout cost ~0.1 s a build); it
    # must print what rich's default table prints to a file, title wrapping included.
    from rich.console import Console
    from rich.table import Table

    from usdworld.cli.summary import COLUMNS, format_table

    # rich shrinks and ellipsises columns beyond the console's width (160 here); the summary never
    # cuts a name, so the two agree on the tables that fit, which is what is compared.
    widths = [max([len(c)] + [len(r[i]) for r in rows]) for i, c in enumerate(COLUMNS)]
    assume(sum(widths) + 3 * len(widths) + 1 <= 160)
    title = " ".join(words)
    table = Table(title=title)
    for column in COLUMNS:
        table.add_column(column, justify="right" if column.endswith(("m", "scale", "deg")) else "left")
    for row in rows:
        table.add_row(*row)
    text = io.StringIO()
    Console(file=text, width=160).print(table)
    assert format_table(title, COLUMNS, rows) == text.getvalue()


def test_build_summary_says_where_the_sun_comes_from_and_how_sure_it_is() -> None:
    from usdworld.cli.summary import light_line

    light = {"method": "cast_shadows", "sun_azimuth_deg": 141.6, "sun_elevation_deg": 50.2, "fit_iou": 0.512, "fit_casters": 7}
    assert light_line(light) == "light: sun azimuth 142 deg, elevation 50 deg (fitted to the shadows of 7 objects, overlap 0.51)"
    weak = dict(light, method="weak_fit", sun_azimuth_deg=135.0, sun_elevation_deg=45.0, fit_iou=0.2, fit_casters=1)
    assert light_line(weak) == (
        "light: sun azimuth 135 deg, elevation 45 deg "
        "(the default: the shadow fit is too weak to trust (overlap 0.20, 1 objects))"
    )
    assert light_line(dict(light, method="overcast")) == "light: overcast (no cast shadows next to the objects)"
