"""What the command benchmarks share: timing a subprocess in wall-clock and CPU time.

Imported by the ``tools/bench_*.py`` scripts (run as ``python tools/bench_x.py``, so this
folder is on ``sys.path``).
"""

from __future__ import annotations

import resource
import subprocess
import time


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
