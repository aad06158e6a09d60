"""The bundled demo sample: a synthetic Cityscapes-format frame shipped in ``usdworld/demo_data``."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from usdworld.errors import InputError

if TYPE_CHECKING:
    from usdworld.pipeline import BuildRequest

DEMO_NAME = "demo_000000_000019"


def demo_dir() -> Path:
    """Folder of the demo files (the render command, the HTML report and the server look for a
    world's photo there: the module loads no pipeline until a demo build asks for one)."""
    return Path(__file__).resolve().parent / "demo_data"


def demo_request(output: Path) -> BuildRequest:
    """The build request for the demo frame."""
    from usdworld.pipeline import BuildRequest

    d = demo_dir()
    files = {
        "image": d / f"{DEMO_NAME}_leftImg8bit.png",
        "labels": d / f"{DEMO_NAME}_gtFine_labelIds.png",
        "instances": d / f"{DEMO_NAME}_gtFine_instanceIds.png",
        "camera": d / f"{DEMO_NAME}_camera.json",
    }
    missing = [p.name for p in files.values() if not p.is_file()]
    if missing:
        raise InputError(f"demo data missing from {d}: {', '.join(missing)}; reinstall usdworld")
    return BuildRequest(output=output, **files)
