"""README.md runs as written: its ```bash commands, in order, in one empty folder.

Every command of every ```bash block is run (``usdworld`` in this process, through
:func:`usdworld.cli.main.main`, with the folder as the working directory and as ``$HOME``),
except those this module's rules leave out, each with its reason:

* :data:`NOT_RUN`: installs, the test suite itself, and ``usdworld serve`` (a server that
  runs until Ctrl-C; tests/test_serve_*.py cover it);
* :data:`OUTSIDE_DATA`: commands naming data that does not ship (Cityscapes, KITTI and
  nuScenes files, your own photos, detections and batch manifests, network weights);
* commands naming a folder that a left-out command would have written (``-o``).

The reader's own model in the assets example (``my_car.glb``) is written by the test as a
stand-in (:data:`STAND_INS`). omni-asset-validator is switched off for the run (it takes
about 10 s per USD export here; tests/test_export*.py run it on exports). A failing command
fails the test with the command and its output.
"""

from __future__ import annotations

import re
import shlex
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest
import trimesh

from usdworld.cli.main import main

README = Path(__file__).resolve().parents[1] / "README.md"

#: Commands never run by the test, and why.
NOT_RUN = (
    (r"\bpip install\b|setup_test_env\.sh|setup_web\.sh", "installs packages"),
    (r"\bpytest\b", "runs the test suite itself"),
    (r"^usdworld serve\b", "a server that runs until Ctrl-C (tests/test_serve_*.py)"),
)
#: Data the README names that does not ship with usdworld: pattern -> what it is.
OUTSIDE_DATA = (
    (r"frankfurt_\d+_\d+", "Cityscapes files"),
    (r"\b\d{6}\.(png|txt)\b|\blabel_2/|\bcalib/|\bplanes/|\bkitti/", "KITTI files"),
    (r"\bcityscapes/", "a Cityscapes dataset folder"),
    (r"\bstreet\.jpg\b|\bstreet_detections\.json\b|\bdet\.json\b", "your own photo and detections"),
    (r"\bframes\.json\b", "a batch manifest of your frames"),
    (r"\.pkl\.DERIVED\.json\b", "a nuScenes info file"),
    (r"--dataroot\b", "the nuScenes dataset"),
    (r"\bviews\.json\b", "your own views manifest"),
    (r"--depth-weights\b|--depth-map\b", "network weights or a depth file"),
)
#: Every kind of example that must run (the first word after ``usdworld``).
MUST_RUN = ("demo", "render", "flythrough", "synth", "build", "evaluate", "edit", "vary", "export", "assets")


def _write_my_car(path: Path) -> None:
    """A pickup as a user would bring it: centimetres, Y up, facing +X (what the README's flags say)."""
    body = trimesh.creation.box(extents=(520.0, 110.0, 190.0))
    body.apply_translation((0.0, 55.0, 0.0))
    cabin = trimesh.creation.box(extents=(200.0, 80.0, 180.0))
    cabin.apply_translation((60.0, 150.0, 0.0))
    scene = trimesh.Scene()
    scene.add_geometry(body, geom_name="body")
    scene.add_geometry(cabin, geom_name="cabin")
    path.write_bytes(scene.export(file_type="glb"))


#: Files the README's commands expect the reader to have, written by the test instead.
STAND_INS: dict[str, Callable[[Path], None]] = {"my_car.glb": _write_my_car}


@dataclass(frozen=True)
class Step:
    """One README command and whether (and why not) the test runs it."""

    text: str
    argv: tuple[str, ...]
    skip: str = ""


def readme_commands(text: str) -> list[str]:
    """The commands of every ```bash block, in order: continuation lines joined, comments and ``&&`` split off."""
    commands: list[str] = []
    for block in re.findall(r"^```bash\n(.*?)^```", text, flags=re.DOTALL | re.MULTILINE):
        for line in block.replace("\\\n", " ").splitlines():
            words = shlex.split(line, comments=True)
            current: list[str] = []
            for word in [*words, "&&"]:
                if word == "&&":
                    if current:
                        commands.append(shlex.join(current))
                    current = []
                else:
                    current.append(word)
    return commands


def _outputs(argv: tuple[str, ...]) -> list[str]:
    return [argv[i + 1] for i, w in enumerate(argv[:-1]) if w in ("-o", "--output")]


def plan(commands: list[str]) -> list[Step]:
    """Each command with the reason it is not run ('' when it is)."""
    steps: list[Step] = []
    unwritten: list[str] = []  # folders and files left-out commands would have written
    for text in commands:
        argv = tuple(shlex.split(text))
        reason = next((why for pattern, why in NOT_RUN if re.search(pattern, text)), "")
        if not reason:
            needs = [what for pattern, what in OUTSIDE_DATA if re.search(pattern, text)]
            reason = f"needs outside data: {', '.join(needs)}" if needs else ""
        if not reason:
            used = [
                out for out in unwritten if any(w == out or w.startswith(out.rstrip("/") + "/") for w in argv)
            ]
            reason = f"uses {used[0]}, which a left-out command writes" if used else ""
        if reason:
            unwritten.extend(_outputs(argv))
        steps.append(Step(text, argv, reason))
    return steps


def test_plan_runs_every_kind_of_example_and_says_why_it_leaves_one_out() -> None:
    steps = plan(readme_commands(README.read_text(encoding="utf-8")))
    run = [s for s in steps if not s.skip]
    assert all(s.argv[0] == "usdworld" for s in run), [s.text for s in run if s.argv[0] != "usdworld"]
    assert set(MUST_RUN) <= {s.argv[1] for s in run}, {s.argv[1] for s in run}
    left_out = {s.text: s.skip for s in steps if s.skip}
    # what is left out, and only that: installs, the suite, the server, and the real-data examples
    assert left_out["usdworld serve demo_world/world.usda"].startswith("a server")
    assert left_out["python3 -m pytest -q -n auto"] == "runs the test suite itself"
    assert all(
        re.match(
            r"(installs|runs the test suite|a server|needs outside data|uses \S+, which a left-out)", why
        )
        for why in left_out.values()
    )
    assert (
        left_out["usdworld info worlds/kitti_8/world.usda"]
        == "uses worlds/kitti_8, which a left-out command writes"
    )
    assert "usdworld demo -o demo_world" not in left_out


def test_plan_reads_blocks_continuations_and_comments() -> None:
    text = "```bash\nusdworld a x \\\n    --y 'q r' # note\npip install . && usdworld b -o w\n```\n```json\n{}\n```\n```bash\nusdworld c w/world.usda\n```\n"
    assert readme_commands(text) == [
        "usdworld a x --y 'q r'",
        "pip install .",
        "usdworld b -o w",
        "usdworld c w/world.usda",
    ]
    steps = plan(
        ["usdworld build 000008.png -o worlds/k", "usdworld info worlds/k/world.usda", "usdworld info w"]
    )
    assert [s.skip for s in steps] == [
        "needs outside data: KITTI files",
        "uses worlds/k, which a left-out command writes",
        "",
    ]


def test_readme_commands_run_in_an_empty_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from usdworld.authoring import validate

    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.delenv("USDWORLD_LIBRARY", raising=False)
    monkeypatch.setattr(validate, "omni_validator_available", lambda: False)
    for name, write in STAND_INS.items():
        write(tmp_path / name)
    for step in plan(readme_commands(README.read_text(encoding="utf-8"))):
        if step.skip:
            continue
        argv = [str(Path(w).expanduser()) if w.startswith("~/") else w for w in step.argv[1:]]
        code = main(argv)
        out, err = capsys.readouterr()
        if code != 0:
            pytest.fail(f"README command failed (exit {code}): {step.text}\n{out[-2000:]}\n{err[-2000:]}")
    for made in (
        "demo_world/world.usda",
        "demo_render/render.png",
        "demo_fly.mp4",
        "synth_world/world.usda",
        "demo.glb",
    ):
        assert (tmp_path / made).is_file(), made
    assert "pickup" in (tmp_path / "usdworld-assets" / "car.usda").read_text()
