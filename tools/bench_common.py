"""What the command benchmarks share: timing a subprocess in wall-clock and CPU time, and the
synthetic world they time.

Imported by the ``tools/bench_*.py`` scripts (run as ``python tools/bench_x.py``, so this
folder is on ``sys.path``).
"""

from __future__ import annotations

import resource
import subprocess
import time
from pathlib import Path


def children_cpu_s() -> float:
    """CPU seconds (user + system) of this process's finished children so far."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_timed(argv: list[str], env: dict[str, str]) -> tuple[float, float, str]:
    """(wall s, CPU s, stdout) of one subprocess; exits with its stderr's tail when it fails."""
    cpu0, t0 = children_cpu_s(), time.perf_counter()
    proc = subprocess.run(argv, env=env, capture_output=True, text=True, check=False)
    wall, cpu = time.perf_counter() - t0, children_cpu_s() - cpu0
    if proc.returncode != 0:
        raise SystemExit(f"failed: {' '.join(argv)}\n{proc.stderr[-2000:]}")
    return wall, cpu, proc.stdout


def synth_world(folder: Path, seed: int = 3, width: int = 2048, height: int = 1024) -> Path:
    """Build the synthetic Cityscapes-format street ``seed`` at ``width`` x ``height`` into
    ``folder`` (its inputs in ``in/``, the world in ``world/``); returns the world's root file."""
    import numpy as np

    from usdworld.pipeline import BuildRequest, build
    from usdworld.synth import make_street_scene, write_cityscapes_frame

    scene = make_street_scene(np.random.default_rng(seed), width, height)
    files = write_cityscapes_frame(scene, folder / "in", "bench_000000_000001")
    request = BuildRequest(
        image=files["image"],
        labels=files["labels"],
        instances=files["instances"],
        camera=files["camera"],
        output=folder / "world",
    )
    return build(request).world
