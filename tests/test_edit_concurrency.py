"""Two editors at once lose no edit; a crash during save leaves the previous layer readable."""

from __future__ import annotations

import itertools
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from pxr import Sdf
from test_edit_support import base_x, fresh_world, sha256

from usdworld.authoring.edits import WorldEditor
from usdworld.authoring.validate import errors_only, validate_file

REPO = Path(__file__).resolve().parents[1]
MOVES = 100
LAG = 5  # how many moves one writer may run ahead of the other

_MOVER = textwrap.dedent(
    """
    import os, sys, time
    from pathlib import Path
    from usdworld.authoring.edits import WorldEditor
    world, name, other = sys.argv[1], sys.argv[2], sys.argv[7]
    x0, y0, n = float(sys.argv[3]), float(sys.argv[4]), int(sys.argv[5])
    go = Path(sys.argv[6])

    def progress(who):
        try:
            return int((go.parent / f"done-{who}").read_text() or 0)
        except (FileNotFoundError, ValueError):
            return 0

    with WorldEditor(world) as editor:
        (go.parent / f"ready-{name}").touch()
        while not go.exists():  # start together, so the two really contend for the lock
            time.sleep(0.001)
        for i in range(n):
            editor.move(name, to=(round(x0 + 0.01 * (i % 50), 3), round(y0 + 0.001 * i, 4)))
            tmp = go.parent / f".done-{name}.tmp"
            tmp.write_text(str(i + 1))
            os.replace(tmp, go.parent / f"done-{name}")
            # Never more than LAG moves ahead of the other writer: the scheduler alone may run one
            # process to the end before the other starts (seen at load 20-30), and then nothing is
            # tested. With the bound, the two must interleave, whatever the load.
            deadline = time.monotonic() + 120
            while progress(other) < i + 1 - LAG:
                if time.monotonic() > deadline:
                    sys.exit(f"{other} made no progress for 120 s")
                time.sleep(0.001)
    """
).replace("LAG", str(LAG))


def _python(code: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", code, *args],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )


def test_two_processes_editing_at_once_lose_no_edit(tmp_path_factory, tmp_path):
    world = fresh_world(tmp_path_factory, tmp_path / "world")
    base = sha256(world.parent / "layers/base.usda")
    jobs = [("car_0001", 22.3, 1.67), ("person_0001", 12.1, -6.56)]
    go = tmp_path / "go"
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", _MOVER, str(world), name, str(x), str(y), str(MOVES), str(go), other],
            cwd=REPO,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for (name, x, y), (other, _, _) in zip(jobs, jobs[::-1])
    ]
    deadline = time.monotonic() + 120
    while (
        not all((tmp_path / f"ready-{name}").exists() for name, _, _ in jobs) and time.monotonic() < deadline
    ):
        time.sleep(0.01)
    go.touch()
    for p in procs:
        _, err = p.communicate(timeout=300)
        assert p.returncode == 0, err
    layer = Sdf.Layer.OpenAsAnonymous(str(world.parent / "layers/edits.usda"))  # parses: not corrupt
    assert layer is not None
    with WorldEditor(world) as editor:
        history = editor.history()
        assert len(history) == 2 * MOVES
        assert [h.step for h in history] == list(range(1, 2 * MOVES + 1))
        names = [h.args["name"] for h in history]
        # The lag bound makes them interleave: a writer's move j waits until the other has made j - 1 - LAG,
        # so a run of one writer's steps starts at most LAG + 1 behind the other and ends LAG + 1 ahead.
        runs = [len(list(run)) for _, run in itertools.groupby(names)]
        assert len(runs) >= 2 * MOVES // (2 * (LAG + 1)) and max(runs) <= 2 * (LAG + 1)
        objects = {o.name: o for o in editor.objects()}
        for name, x0, y0 in jobs:
            mine = [h.args["to"] for h in history if h.args["name"] == name]
            assert mine == [[round(x0 + 0.01 * (i % 50), 3), round(y0 + 0.001 * i, 4)] for i in range(MOVES)]
            assert objects[name].position_world[:2] == pytest.approx(tuple(mine[-1]))
        editor.undo(2 * MOVES)  # and every step undoes back to the empty layer
    assert (world.parent / "layers/edits.usda").read_text() == "#usda 1.0\n\n"
    assert sha256(world.parent / "layers/base.usda") == base
    assert errors_only(validate_file(world, omni=False)) == []


_CRASHER = textwrap.dedent(
    """
    import os, signal, sys
    from usdworld.authoring.edits import WorldEditor
    editor = WorldEditor(sys.argv[1])
    def die(fd):
        os.kill(os.getpid(), signal.SIGKILL)  # power cut: the new text is in a temp file, not yet renamed
    os.fsync = die
    editor.move("car_0001", by=(2.0, 0.0))
    """
)


def test_crash_during_save_leaves_the_previous_layer(tmp_path_factory, tmp_path):
    world = fresh_world(tmp_path_factory, tmp_path / "world")
    with WorldEditor(world) as editor:
        editor.move("car_0001", by=(1.0, 0.0))
    edits = world.parent / "layers/edits.usda"
    before = edits.read_text()
    result = _python(_CRASHER, str(world))
    assert result.returncode == -9, result.stderr
    assert edits.read_text() == before
    assert Sdf.Layer.OpenAsAnonymous(str(edits)) is not None
    assert list(edits.parent.glob(".edits.usda.*.tmp"))  # the dead writer's temp file
    with WorldEditor(world) as editor:
        assert [h.args for h in editor.history()] == [{"name": "car_0001", "by": [1.0, 0.0]}]
        editor.move("car_0001", by=(1.0, 0.0))
        assert not list(edits.parent.glob(".edits.usda.*.tmp"))  # cleaned up under the lock
        assert [o.position_world[0] for o in editor.objects() if o.name == "car_0001"][0] == pytest.approx(
            base_x(world, "car_0001") + 2.0, abs=0.01
        )


def test_an_editor_waits_for_the_lock(tmp_path_factory, tmp_path):
    import threading

    from filelock import FileLock

    world = fresh_world(tmp_path_factory, tmp_path / "world")
    held = FileLock(world.parent / "layers/edits.usda.lock")  # another editor's, in another thread
    taken, released = threading.Event(), []

    def hold() -> None:
        with held:
            taken.set()
            time.sleep(0.3)
            released.append(time.monotonic())

    threading.Thread(target=hold).start()
    assert taken.wait(30)
    with WorldEditor(world) as editor:
        assert editor.delete("car_0001").step == 1
        done = time.monotonic()
    assert released and done >= released[0]  # it blocked until the holder let go
