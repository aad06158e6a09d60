"""Regenerate the codeless schema plugin in ``schemas/`` from ``schemas/schema.usda``.

Runs OpenUSD's ``usdGenSchema`` (needs ``jinja2``) into a temporary folder, fills in
the CMake placeholders of ``plugInfo.json`` for a resource-only plugin and writes
``schemas/plugInfo.json`` and ``schemas/generatedSchema.usda``.

Usage::

    python tools/gen_schema.py           # rewrite the generated files
    python tools/gen_schema.py --check   # exit 1 when they are stale
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

SCHEMAS = Path(__file__).resolve().parent.parent / "schemas"
PLACEHOLDERS = {
    '"@PLUG_INFO_LIBRARY_PATH@"': '""',
    '"@PLUG_INFO_RESOURCE_PATH@"': '"."',
    '"@PLUG_INFO_ROOT@"': '"."',
}


def generate() -> dict[str, str]:
    """Run usdGenSchema and return ``{file name: text}`` of the generated files."""
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run(
            [sys.executable, "-m", "pxr.Usd.usdGenSchema", str(SCHEMAS / "schema.usda"), tmp],
            check=True,
            capture_output=True,
        )
        plug = (Path(tmp) / "plugInfo.json").read_text()
        for old, new in PLACEHOLDERS.items():
            plug = plug.replace(old, new)
        schema = (Path(tmp) / "generatedSchema.usda").read_text()
    return {"plugInfo.json": plug, "generatedSchema.usda": schema}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="only report stale files")
    args = parser.parse_args()
    stale = []
    for name, text in generate().items():
        path = SCHEMAS / name
        if path.exists() and path.read_text() == text:
            continue
        stale.append(name)
        if not args.check:
            path.write_text(text)
    if args.check and stale:
        print(f"stale: {', '.join(stale)}; run python tools/gen_schema.py", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
