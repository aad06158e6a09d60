"""Where the package's shipped resources live (leaf module, no pxr import).

In a wheel the top-level ``schemas/`` and ``asset_library/`` folders are installed
inside the package; in a source checkout (editable install, tests) they sit next to
the package folder.
"""

from __future__ import annotations

import os
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


#: Environment variable naming the folder of real evaluation data (kitti/, cityscapes/, nuscenes/).
DATA_ENV = "USDWORLD_DATA"


def evaluation_data_dir() -> Path:
    """Folder of the real evaluation data (non-commercial, never in the repository).

    ``$USDWORLD_DATA`` when set, else ``shared/data`` beside the source checkout (the folder
    holding this checkout's parent: ``../shared/data`` seen from the repository root). The
    folder may not exist; callers that need it skip or fail with their own message.
    """
    env = os.environ.get(DATA_ENV, "").strip()
    if env:
        return Path(env).expanduser()
    return _PACKAGE.parent.parent / "shared" / "data"
