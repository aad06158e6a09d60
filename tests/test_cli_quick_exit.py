"""Every ``usdworld`` sub-command ends its process without the interpreter's teardown, after the
threads that are not daemons and the exit handlers, with its output flushed; help exits as usual."""

from __future__ import annotations

import gc
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
    monkeypatch.setattr(cli.threading, "_shutdown", lambda: calls.append("threads"))
    monkeypatch.setattr(cli.atexit, "_run_exitfuncs", lambda: calls.append("atexit"))
    monkeypatch.setattr(cli.os, "_exit", fake_exit)
    collecting = gc.isenabled()
    try:
        with pytest.raises((_Exited, SystemExit)) as exc:
            cli.run()
    finally:  # run() turns the collector off for build and render and freezes: pytest goes on
        gc.unfreeze()
        if collecting:
            gc.enable()
    return calls, exc.value.code


def test_an_edit_runs_the_exit_handlers_then_ends_the_process(
    tmp_path_factory, tmp_path, monkeypatch, capsys
):
    root = fresh_world(tmp_path_factory, tmp_path / "world")
    edits = root.parent / "layers" / "edits.usda"
    before = edits.read_bytes()
    calls, code = _run(monkeypatch, ["-q", "edit", str(root), "move", "car_0001", "--by", "0.5,0", "--force"])
    assert (calls, code) == (["threads", "atexit", "os._exit"], 0)
    assert edits.read_bytes() != before  # saved before the process ends
    calls, code = _run(monkeypatch, ["edit", str(root), "move", "no_such_0001", "--by", "1,0"])
    assert (calls, code) == (["threads", "atexit", "os._exit"], 2)
    assert capsys.readouterr().err.startswith("error: no object 'no_such_0001'")


def _python(code: str) -> subprocess.CompletedProcess:
    """Run ``code`` in a fresh interpreter that imports this checkout; it must exit 0."""
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return done


@pytest.mark.parametrize("argv", [["build", "photo.png"], ["-q", "render", "W"], ["serve", "W"], ["batch", "in", "-o", "o"]])
def test_every_sub_command_ends_its_process_the_same_way(monkeypatch, argv):
    monkeypatch.setattr(cli, "main", lambda args: 3)
    calls, code = _run(monkeypatch, argv)
    assert (calls, code) == (["threads", "atexit", "os._exit"], 3)


@pytest.mark.parametrize("argv", [["--help"], [], ["no-such-command"]])
def test_help_and_unknown_commands_exit_normally(monkeypatch, argv):
    monkeypatch.setattr(cli, "main", lambda args: 0)
    calls, code = _run(monkeypatch, argv)
    assert (calls, code) == ([], 0)


def test_a_thread_that_is_no_daemon_finishes_before_the_process_ends(tmp_path_factory, tmp_path):
    """As at a normal exit: a worker a command (or a library it used) left running gets to finish."""
    root = fresh_world(tmp_path_factory, tmp_path / "world")
    code = (
        "import sys, threading, time\n"
        "def worker():\n"
        "    while threading.main_thread().is_alive():  # until the command has returned\n"
        "        time.sleep(0.01)\n"
        "    print('worker finished')\n"
        "threading.Thread(target=worker, daemon=False).start()\n"
        "from usdworld.cli.main import run\n"
        f"sys.argv = ['usdworld', '-q', 'info', {str(root)!r}]\n"
        "run()\n"
    )
    done = _python(code)
    assert done.stdout.splitlines()[-1] == "worker finished"


def test_the_edit_process_flushes_its_output_and_runs_atexit_handlers(tmp_path_factory, tmp_path):
    root = fresh_world(tmp_path_factory, tmp_path / "world")
    code = (
        "import atexit, sys\n"
        "atexit.register(lambda: print('exit handler ran'))\n"
        "from usdworld.cli.main import run\n"
        f"sys.argv = ['usdworld', 'edit', {str(root)!r}, 'move', 'car_0001', '--by', '0.5,0', '--force']\n"
        "run()\n"
    )
    done = _python(code)
    said, handler = done.stdout.splitlines()  # a pipe: block-buffered, flushed before the end
    assert said.startswith("moved car_0001 to (") and said.endswith(" on road [step 1]")
    assert handler == "exit handler ran"
