"""``usdworld edit`` ends its process without the interpreter's teardown, after the exit handlers
and with its output flushed; the other commands exit as before."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from test_edit_support import fresh_world

from usdworld.cli import main as cli

REPO = Path(__file__).resolve().parents[1]


class _Exited(Exception):
    def __init__(self, code: int) -> None:
        self.code = code


def _run(monkeypatch, argv: list[str]) -> tuple[list[str], int]:
    """Run the console entry point in process; the calls it made and the exit code."""
    calls: list[str] = []

    def fake_exit(code: int) -> None:
        calls.append("os._exit")
        raise _Exited(code)

    monkeypatch.setattr(sys, "argv", ["usdworld", *argv])
    monkeypatch.setattr(cli.atexit, "_run_exitfuncs", lambda: calls.append("atexit"))
    monkeypatch.setattr(cli.os, "_exit", fake_exit)
    with pytest.raises((_Exited, SystemExit)) as exc:
        cli.run()
    return calls, exc.value.code


def test_an_edit_runs_the_exit_handlers_then_ends_the_process(
    tmp_path_factory, tmp_path, monkeypatch, capsys
):
    root = fresh_world(tmp_path_factory, tmp_path / "world")
    edits = root.parent / "layers" / "edits.usda"
    before = edits.read_bytes()
    calls, code = _run(monkeypatch, ["-q", "edit", str(root), "move", "car_0001", "--by", "0.5,0", "--force"])
    assert (calls, code) == (["atexit", "os._exit"], 0)
    assert edits.read_bytes() != before  # saved before the process ends
    calls, code = _run(monkeypatch, ["edit", str(root), "move", "no_such_0001", "--by", "1,0"])
    assert (calls, code) == (["atexit", "os._exit"], 2)
    assert capsys.readouterr().err.startswith("error: no object 'no_such_0001'")


def test_other_commands_exit_normally(monkeypatch):
    calls, code = _run(monkeypatch, ["--help"])
    assert (calls, code) == ([], 0)


def test_the_edit_process_flushes_its_output_and_runs_atexit_handlers(tmp_path_factory, tmp_path):
    root = fresh_world(tmp_path_factory, tmp_path / "world")
    code = (
        "import atexit, sys\n"
        "atexit.register(lambda: print('exit handler ran'))\n"
        "from usdworld.cli.main import run\n"
        f"sys.argv = ['usdworld', 'edit', {str(root)!r}, 'move', 'car_0001', '--by', '0.5,0', '--force']\n"
        "run()\n"
    )
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    said, handler = done.stdout.splitlines()  # a pipe: block-buffered, flushed before the end
    assert said.startswith("moved car_0001 to (") and said.endswith(" on road [step 1]")
    assert handler == "exit handler ran"
