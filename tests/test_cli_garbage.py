"""The console entry point's garbage collection: ``build`` and ``render`` run without the cyclic
collector, and every command freezes what is alive before the interpreter's teardown."""

from __future__ import annotations

import gc
import os
import subprocess
import sys
from pathlib import Path

import pytest

from usdworld.cli import main as cli

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture
def restored_gc():
    """Put the collector back as it was (enabled, nothing frozen) after the test."""
    enabled = gc.isenabled()
    yield
    gc.unfreeze()
    if enabled:
        gc.enable()


def _run(monkeypatch, argv: list[str]) -> tuple[bool, int, int]:
    """Run the console entry point with a stand-in ``main``: whether the collector was on while
    the command ran, the objects frozen when the process would exit, and the exit code."""
    seen: list[bool] = []

    def fake_main(args: list[str]) -> int:
        assert args == argv
        seen.append(gc.isenabled())
        return 3

    def fake_quick_exit(code: int) -> None:
        raise SystemExit(code)

    gc.unfreeze()
    monkeypatch.setattr(sys, "argv", ["usdworld", *argv])
    monkeypatch.setattr(cli, "main", fake_main)
    monkeypatch.setattr(cli, "quick_exit", fake_quick_exit)  # the process goes on: it is pytest's
    with pytest.raises(SystemExit) as exc:
        cli.run()
    return seen[0], gc.get_freeze_count(), exc.value.code


@pytest.mark.parametrize("argv", [["build", "photo.png", "-o", "W"], ["-q", "render", "W", "-o", "out"]])
def test_build_and_render_run_without_the_cyclic_collector(monkeypatch, restored_gc, argv):
    collecting, frozen, code = _run(monkeypatch, argv)
    assert not collecting
    assert frozen > 1000  # the modules, classes and functions loaded so far
    assert code == 3


@pytest.mark.parametrize("argv", [["--help"], ["serve", "W"], ["batch", "in", "-o", "out"]])
def test_other_commands_collect_as_usual_and_freeze_before_the_teardown(monkeypatch, restored_gc, argv):
    collecting, frozen, code = _run(monkeypatch, argv)
    assert collecting
    assert frozen > 1000
    assert code == 3


def test_the_module_loads_no_cli_library_before_run_decides():
    """typer is imported when the app is made, after :func:`run` set the collector."""
    probe = "import sys, usdworld.cli.main\nassert 'typer' not in sys.modules, 'typer loaded'"
    subprocess.run([sys.executable, "-c", probe], cwd=REPO, env={**os.environ, "PYTHONPATH": str(REPO)}, check=True)
