"""The ``usdworld`` command: sub-commands, error handling and exit codes.

Exit codes: 0 success, 1 validation failure or unexpected error, 2 bad input or usage.
Errors print one line (``error: ...``) on stderr; ``--debug`` adds the traceback.
Python warnings raised by libraries during a command (numpy's ``RuntimeWarning: overflow``
on a hostile number, say) are held back: after an error they are dropped, so the error
stays one line; after success they are logged as ``WARNING:`` lines. ``--debug`` shows
them as they happen.
"""

from __future__ import annotations

import atexit
import gc
import importlib
import logging
import os
import sys
import threading
import traceback
import warnings
from collections.abc import Sequence
from typing import TYPE_CHECKING, NoReturn

if TYPE_CHECKING:
    import typer

#: Each sub-command and the module (in ``usdworld.cli``) that defines it, in the order
#: ``usdworld --help`` lists them.
COMMANDS = {
    "build": "build_cmd",
    "depth": "depth_cmd",
    "segment": "segment_cmd",
    "batch": "batch_cmd",
    "demo": "demo_cmd",
    "info": "info_cmd",
    "validate": "validate_cmd",
    "render": "render_cmd",
    "flythrough": "flythrough_cmd",
    "synth": "synth_cmd",
    "evaluate": "evaluate_cmd",
    "report": "report_cmd",
    "export": "export_cmd",
    "assets": "assets_cmd",
    "edit": "edit_cmd",
    "vary": "vary_cmd",
    "serve": "serve_cmd",
}
#: Options of the ``usdworld`` command itself (they come before the sub-command).
ROOT_FLAGS = ("--debug", "--quiet", "-q")
#: Sub-commands whose process ends without tearing the interpreter down (see :func:`run`): all.
QUICK_EXIT_COMMANDS = frozenset(COMMANDS)
#: Sub-commands whose process runs without Python's cyclic garbage collector (see :func:`run`).
UNCOLLECTED_COMMANDS = frozenset({"build", "render"})


def _set_logging(debug: bool, quiet: bool) -> None:
    """The root options' effect: ``-q`` for the command's results, the log level and format."""
    from usdworld.cli.output import set_quiet

    set_quiet(quiet)
    level = logging.DEBUG if debug else (logging.WARNING if quiet else logging.INFO)
    logging.basicConfig(level=level, format="%(levelname)s: %(message)s", stream=sys.stderr, force=True)
    for noisy in ("omni", "omni.asset_validator", "omni.asset_validator._plugins"):
        logging.getLogger(noisy).setLevel(logging.WARNING)


def make_app(commands: Sequence[str] = tuple(COMMANDS)) -> typer.Typer:
    """The ``usdworld`` typer app with the given sub-commands (all by default).

    typer is imported here, not with the module, so that :func:`run` decides how the process
    collects garbage before the start-up's imports begin.

    Args:
        commands: names from :data:`COMMANDS`.
    """
    import typer

    def _root(
        debug: bool = typer.Option(False, "--debug", help="Show tracebacks and debug logging."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="Only print warnings and errors."),
    ) -> None:
        _set_logging(debug, quiet)

    app = typer.Typer(
        add_completion=False,
        no_args_is_help=True,
        pretty_exceptions_enable=False,
        # Plain (click) help and usage errors: typer's rich formatting imports rich's markdown,
        # syntax and pygments modules, a third of the start-up of `usdworld --help`.
        rich_markup_mode=None,
        help="One street photo to a layered, editable OpenUSD world.",
    )
    app.callback()(_root)
    for name in commands:
        importlib.import_module(f"usdworld.cli.{COMMANDS[name]}").register(app)
    return app


def commands_for(args: Sequence[str]) -> tuple[str, ...]:
    """The sub-commands the app needs for these arguments.

    Typer builds every registered command (signatures, type hints, parameters) on each run, so
    a run that names its sub-command gets an app with that one only. Help, no arguments or an
    unknown name get them all, so that the listing and the "no such command" error are whole.

    Args:
        args: the command line after ``usdworld``.
    """
    for arg in args:
        if arg in ROOT_FLAGS:
            continue
        return (arg,) if arg in COMMANDS else tuple(COMMANDS)
    return tuple(COMMANDS)


def main(argv: list[str] | None = None) -> int:
    """Run the CLI and return its exit code (never raises for user errors)."""
    from usdworld.cli.output import set_quiet
    from usdworld.errors import UsdWorldError

    args = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in args
    held: list[warnings.WarningMessage] = []
    try:
        with warnings.catch_warnings(record=not debug) as caught:
            try:
                # Standalone mode: typer/click print usage errors and --help themselves and exit.
                make_app(commands_for(args))(args=args, prog_name="usdworld", standalone_mode=True)
            finally:
                held = list(caught or [])
                set_quiet(None)  # the run is over: a later caller in this process is not under its -q
    except SystemExit as exc:
        code = exc.code
        code = code if isinstance(code, int) else (0 if code is None else 1)
        if code == 0:
            _log_held_warnings(held)
        return code
    except UsdWorldError as exc:
        if debug:
            traceback.print_exc()
        print(f"error: {exc}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print("error: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # anything else is a bug: say so in one line
        if debug:
            traceback.print_exc()
        print(
            f"error: unexpected {type(exc).__name__}: {exc} (rerun with --debug for the traceback and report it)",
            file=sys.stderr,
        )
        return 1
    _log_held_warnings(held)
    return 0


def _log_held_warnings(held: list[warnings.WarningMessage]) -> None:
    """Log the library warnings of a successful command, each distinct message once."""
    seen: set[str] = set()
    for w in held:
        text = f"{w.category.__name__}: {w.message} ({w.filename}:{w.lineno})"
        if text not in seen:
            seen.add(text)
            logging.getLogger("usdworld").warning("%s", text)


def run() -> None:
    """Console-script entry point.

    Garbage collection: a command's start-up creates some 50,000 objects that live until the
    process ends (modules, classes, functions of usdworld, typer, numpy and pxr); each of
    Python's cyclic collections looks at those it has not yet promoted, and the interpreter's
    teardown collects once more over all of them. A command of :data:`UNCOLLECTED_COMMANDS`
    (``build``, ``render``: one piece of work, then exit) runs with the cyclic collector off
    from its first import: a build leaves about 500 objects in reference cycles the first time
    in a process and 33 each time after (memory is freed by reference counting as before).
    Every command freezes (:func:`gc.freeze`) what is alive when :func:`main` returns, so the
    teardown's collection skips it: the files the command wrote are closed by then, and the
    exit handlers and module teardown still run as before. Together about 0.1 s of CPU of a
    whole ``usdworld build`` on the 2-core machine (BENCHMARKS.md, thirteenth session).

    A run of a sub-command (:data:`QUICK_EXIT_COMMANDS`: every one) ends its process with
    :func:`quick_exit`: by the time :func:`main` returns, its files are written (atomically),
    an edit's lock is released and its pools are shut down, so what is left is tearing down
    the interpreter and OpenUSD's libraries (module teardown, their registries' static
    destructors). That teardown costs 0.04-0.1 s of CPU after a 10,000-object world's edit on
    the 2-core machine, and it is not safe: OpenUSD destroys a layer's data on a detached
    worker thread (``WorkMoveDestroyAsync``), which can still be running when the static
    destructors run, and the process then aborts ("pure virtual method called", SIGABRT)
    after its work is done. ``--help``, no arguments and unknown names exit as usual.
    """
    args = sys.argv[1:]
    names = commands_for(args)
    command = names[0] if len(names) == 1 else None
    if command in UNCOLLECTED_COMMANDS:
        gc.disable()
    code = main(args)
    gc.freeze()
    if command in QUICK_EXIT_COMMANDS:
        quick_exit(code)
    sys.exit(code)


def quick_exit(code: int) -> NoReturn:
    """End the process with ``code`` the way the interpreter's exit begins, skipping its teardown.

    As :c:func:`Py_FinalizeEx` does first: wait for the threads that are not daemons (and
    shut ``concurrent.futures`` pools down), then run the exit handlers (``atexit``: logging's
    shutdown, Dask's and multiprocessing's clean-up among them); then flush the standard
    streams and end the process.
    """
    threading._shutdown()  # the interpreter's own first step of an exit (no public name for it)
    atexit._run_exitfuncs()  # its second one
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe: nothing left to say there
            pass
    os._exit(code)
