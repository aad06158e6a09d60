"""Pool workers end when the batch process that started them is killed with SIGKILL."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

# The batch stand-in: a pool like LocalPoolExecutor's (spawn, exit_with_parent), one task that
# sleeps, the worker's pid printed; then it waits to be killed.
_BATCH = """
import multiprocessing, os, sys, time
from concurrent.futures import ProcessPoolExecutor
from usdworld.batch.parent_watch import exit_with_parent

def task():
    print(os.getpid(), flush=True)
    time.sleep(120)

if __name__ == "__main__":
    pool = ProcessPoolExecutor(1, mp_context=multiprocessing.get_context(sys.argv[1]),
                               initializer=exit_with_parent, initargs=(os.getpid(),))
    pool.submit(task)
    time.sleep(120)
"""


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    stat = Path(f"/proc/{pid}/stat")
    return not (stat.exists() and stat.read_text().split(") ")[1].startswith("Z"))


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="process checks read /proc")
@pytest.mark.parametrize("method", ["spawn"])  # forkserver works too (the watchdog thread); 15 s more
def test_worker_exits_when_batch_is_killed(tmp_path: Path, method: str) -> None:
    script = tmp_path / "batch.py"
    script.write_text(_BATCH)
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    batch = subprocess.Popen([sys.executable, str(script), method], stdout=subprocess.PIPE, text=True, env=env)
    try:
        assert batch.stdout is not None
        worker = int(batch.stdout.readline())
        assert _alive(worker)
        os.kill(batch.pid, signal.SIGKILL)
        batch.wait(timeout=10)
        deadline = time.monotonic() + 10
        while _alive(worker) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not _alive(worker), "the pool worker outlived its batch process"
    finally:
        if batch.poll() is None:
            batch.kill()
