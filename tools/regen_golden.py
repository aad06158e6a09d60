"""Regenerate the golden ``.usda`` files of ``tests/golden`` (review the diff like code).

Usage::

    python tools/regen_golden.py
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from golden_scene import GOLDEN_DIR, build_golden  # noqa: E402


def main() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        texts = build_golden(Path(tmp))
    for name, text in texts.items():
        target = GOLDEN_DIR / name.replace("/", "__")
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(text)
        print(f"wrote {target}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
