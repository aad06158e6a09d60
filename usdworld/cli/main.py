"""The ``usdworld`` command: sub-commands, error handling and exit codes.

Exit codes: 0 success, 1 validation failure or unexpected error, 2 bad input or usage.
Errors print one line (``error: ...``) on stderr; ``--debug`` adds the traceback.
"""

from __future__ import annotations

import logging
import sys
import traceback

import typer

from usdworld.cli import (
    assets_cmd,
    batch_cmd,
    build_cmd,
    demo_cmd,
    depth_cmd,
    edit_cmd,
    evaluate_cmd,
    export_cmd,
    flythrough_cmd,
    info_cmd,
    render_cmd,
    serve_cmd,
    synth_cmd,
    validate_cmd,
    vary_cmd,
)

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    # Plain (click) help and usage errors: typer's rich formatting imports rich's markdown,
    # syntax and pygments modules, a third of the start-up of `usdworld --help`.
    rich_markup_mode=None,
    help="One street photo to a layered, editable OpenUSD world.",
)


@app.callback()
def _root(
    debug: bool = typer.Option(False, "--debug", help="Show tracebacks and debug logging."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="Only print warnings and errors."),
) -> None:
    level = logging.DEBUG if debug else (logging.WARNING if quiet else logging.INFO)
    logging.basicConfig(level=level, format="%(levelname)s: %(message)s", stream=sys.stderr, force=True)
    for noisy in ("omni", "omni.asset_validator", "omni.asset_validator._plugins"):
        logging.getLogger(noisy).setLevel(logging.WARNING)


build_cmd.register(app)
depth_cmd.register(app)
batch_cmd.register(app)
demo_cmd.register(app)
info_cmd.register(app)
validate_cmd.register(app)
render_cmd.register(app)
flythrough_cmd.register(app)
synth_cmd.register(app)
evaluate_cmd.register(app)
export_cmd.register(app)
assets_cmd.register(app)
edit_cmd.register(app)
vary_cmd.register(app)
serve_cmd.register(app)


def main(argv: list[str] | None = None) -> int:
    """Run the CLI and return its exit code (never raises for user errors)."""
    from usdworld.errors import UsdWorldError

    args = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in args
    try:
        # Standalone mode: typer/click print usage errors and --help themselves and exit.
        app(args=args, prog_name="usdworld", standalone_mode=True)
    except SystemExit as exc:
        code = exc.code
        return code if isinstance(code, int) else (0 if code is None else 1)
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
    return 0


def run() -> None:
    """Console-script entry point."""
    sys.exit(main())
