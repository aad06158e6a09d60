"""Pool workers that end when the batch process that started them dies.

A ``ProcessPoolExecutor`` worker blocks on its call queue; when the batch process is
killed with SIGKILL nobody tells it, and it would go on building frames nobody collects.
:func:`exit_with_parent` runs as the pool's initializer in each worker:

* on Linux it asks the kernel for SIGKILL when its parent dies (``prctl(PR_SET_PDEATHSIG)``,
  through ctypes), which acts at once;
* everywhere, a daemon thread checks every :data:`POLL_S` seconds that the batch process
  is alive and that the worker has not been re-parented, and ends the worker otherwise
  (this also covers ``forkserver``, whose workers are the fork server's children).
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import sys
import threading
import time

#: Seconds between two checks of the watchdog thread.
POLL_S = 0.5

#: ``PR_SET_PDEATHSIG`` from <linux/prctl.h>.
_PR_SET_PDEATHSIG = 1


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else (the pid was reused)
        return False
    return True


def _watch(batch_pid: int, parent_pid: int) -> None:
    while True:
        time.sleep(POLL_S)
        if os.getppid() != parent_pid or not _alive(batch_pid):
            os._exit(1)


def exit_with_parent(batch_pid: int) -> None:
    """Make this worker process end when the batch process ``batch_pid`` ends.

    Args:
        batch_pid: process id of the batch process that made the pool.
    """
    parent_pid = os.getppid()
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    if not _alive(batch_pid):  # it died before the request took effect
        os._exit(1)
    threading.Thread(target=_watch, args=(batch_pid, parent_pid), daemon=True, name="usdworld-parent-watch").start()
