"""Every third-party module usdworld imports is a declared dependency (a fresh install runs).

A module found only because the development machine happens to have it (``click`` through
another package, say) breaks the README's first command on a fresh machine. This reads the
imports of every module (top-level and lazy ones; imports under ``if TYPE_CHECKING:`` only
serve annotations and are left out) and checks them against ``pyproject.toml``: the modules of
the core install may use only core dependencies; the extras' modules their extra's too.
"""

from __future__ import annotations

import ast
import re
import sys
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PACKAGE = REPO / "usdworld"

#: Import name -> distribution name, for every third-party module usdworld may import.
DISTRIBUTION = {
    "PIL": "pillow",
    "cv2": "opencv-python-headless",
    "dask": "dask",
    "distributed": "dask",
    "filelock": "filelock",
    "imageio_ffmpeg": "imageio-ffmpeg",
    "manifold3d": "manifold3d",
    "mapbox_earcut": "mapbox-earcut",
    "moderngl": "moderngl",
    "numpy": "numpy",
    "nuscenes": "nuscenes-devkit",
    "omni": "omniverse-asset-validator",
    "pxr": "usd-core",
    "rich": "rich",
    "scipy": "scipy",
    "starlette": "starlette",
    "torch": "torch",
    "transformers": "transformers",
    "trimesh": "trimesh",
    "typer": "typer",
    "uvicorn": "uvicorn",
}
#: Modules that run only with an extra installed (relative to usdworld/), and the extra.
EXTRA_MODULES = {
    "render/": "render",
    "batch/dask_executor.py": "batch",
    "perception/depth/monodepth.py": "depth",
    "perception/depth/monodepth2.py": "depth",
    "perception/depth/runtime.py": "depth",
    "perception/depth/hf.py": "depth",
    "perception/segment/hf.py": "segment",
    "serve/": "serve",
    "cli/serve_cmd.py": "serve",
    "views/nuscenes_devkit.py": "nuscenes",
}


def _names(requirements: list[str]) -> set[str]:
    return {re.split(r"[<>=!~\[; ]", r.strip(), maxsplit=1)[0].lower() for r in requirements}


def _imports(path: Path) -> set[str]:
    """Top-level names of the absolute imports of a module, outside ``if TYPE_CHECKING:``."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skipped = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skipped.update(id(n) for child in node.body for n in ast.walk(child))
    names = set()
    for node in ast.walk(tree):
        if id(node) in skipped:
            continue
        if isinstance(node, ast.Import):
            names.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return {n for n in names if n not in sys.stdlib_module_names and n not in ("usdworld", "__future__")}


def test_every_import_is_a_declared_dependency_of_its_install() -> None:
    project = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    core = _names(project["dependencies"])
    extras = {name: _names(reqs) for name, reqs in project["optional-dependencies"].items()}
    problems = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE).as_posix()
        extra = next((e for prefix, e in EXTRA_MODULES.items() if rel.startswith(prefix)), None)
        allowed = core | (extras[extra] if extra else set())
        for module in sorted(_imports(path)):
            dist = DISTRIBUTION.get(module)
            if dist is None:
                problems.append(f"{rel}: imports {module}, which no entry of DISTRIBUTION names")
            elif dist not in allowed:
                where = f"the '{extra}' extra" if extra else "the core dependencies"
                problems.append(f"{rel}: imports {module} ({dist}), not in {where}")
    assert problems == []
