"""Where the package's shipped resources live (leaf module, no pxr import).

In a wheel the top-level ``schemas/`` and ``asset_library/`` folders are installed
inside the package; in a source checkout (editable install, tests) they sit next to
the package folder.
"""

from __future__ import annotations

from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent


def _find(name: str) -> Path:
    for candidate in (_PACKAGE / name, _PACKAGE.parent / name):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(
        f"usdworld resource folder '{name}' is missing from {_PACKAGE}; reinstall usdworld"
    )


def schemas_dir() -> Path:
    """Folder holding the codeless schema plugin (``plugInfo.json``)."""
    return _find("schemas")


def asset_library_dir() -> Path:
    """Folder holding the built-in class assets (``<class>.usda``)."""
    return _find("asset_library")


def data_dir() -> Path:
    """Folder holding the package's data tables (class table, priors, rules)."""
    return _PACKAGE / "data"
