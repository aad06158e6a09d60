"""One edit = one transaction on the edits layer: lock, sync with the file, author, atomic save.

The lock is an exclusive ``flock`` on ``<edits layer>.lock`` on POSIX (:mod:`fcntl`, what
:class:`filelock.FileLock` takes there: the two exclude each other), a :class:`filelock.FileLock`
(``LockFileEx``) on Windows, held for the whole transaction. A waiting POSIX editor sleeps in
``flock`` until the holder lets go; a Windows one polls every :data:`LOCK_POLL_S`. The lock goes
away with its holder's process, so a crashed editor never leaves the world locked. Saves write
a temporary file in the same folder, fsync it and rename it over the layer, so readers and a
crash see the old or the new layer, never a mix.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator
from pathlib import Path

from pxr import Sdf, Tf

from usdworld.atomic import write_text_atomic
from usdworld.errors import AuthoringError, OutputError

#: Seconds between two tries of a waiting editor to take the lock where there is no ``flock`` (Windows).
LOCK_POLL_S = 0.01


def atomic_write_text(path: Path, text: str) -> None:
    """Write a layer so that readers see the old or the new content, never a mix (flushed to disk)."""
    write_text_atomic(path, text, fsync=True)


def lock_path_of(edits_path: Path) -> Path:
    """The lock file of an edits layer: ``<edits layer>.lock`` beside it."""
    return edits_path.with_name(edits_path.name + ".lock")


@contextlib.contextmanager
def edit_lock(path: Path) -> Iterator[None]:
    """Hold the exclusive lock ``path`` (created when missing), waiting as long as it takes.

    On POSIX this is ``fcntl.flock`` itself: filelock's import costs an edit command 10-20 ms
    of CPU (its logging, hashing, secrets and decimal modules) for the same system call.

    Raises:
        AuthoringError: the lock file cannot be created (e.g. a read-only folder).
    """
    try:
        import fcntl
    except ImportError:  # Windows
        with _file_lock(path):
            yield
        return
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as exc:
        raise AuthoringError(
            f"{path}: cannot create the edit lock ({exc.strerror or exc}); is the folder writable?"
        ) from exc
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)  # waits for another editor's transaction to end
        yield
    finally:
        os.close(fd)  # closing the only descriptor of this open file releases its flock


@contextlib.contextmanager
def _file_lock(path: Path) -> Iterator[None]:
    """:func:`edit_lock` where there is no ``flock``: filelock's portable lock."""
    from filelock import FileLock  # ~25 ms: only once a transaction needs it

    lock = FileLock(path, timeout=-1, thread_local=False)
    try:
        lock.acquire(poll_interval=LOCK_POLL_S)
    except OSError as exc:
        raise AuthoringError(
            f"{path}: cannot create the edit lock ({exc.strerror or exc}); is the folder writable?"
        ) from exc
    try:
        yield
    finally:
        lock.release()


class EditsTransaction:
    """The edits layer in memory, kept in line with its file, and written only under the lock.

    Args:
        edits: the edits layer (the root layer's first sublayer).
        watched: the root and base layer files; when one changes on disk (a rebuild), they
            are reloaded and ``on_reload`` is called (the state reader drops its caches).
        on_reload: called after the watched layers were reloaded.
    """

    def __init__(self, edits: Sdf.Layer, watched: tuple[Path, ...], on_reload: Callable[[], None]) -> None:
        self.layer = edits
        self.path = Path(edits.realPath)
        self.lock_path = lock_path_of(self.path)
        self._watched = watched
        self._on_reload = on_reload
        self._synced: bytes | None = None
        self._stamp = self._watched_stamp()

    def _watched_stamp(self) -> tuple:
        out = []
        for p in self._watched:
            st = p.stat()
            out.append((st.st_ino, st.st_mtime_ns, st.st_size))
        return tuple(out)

    def sync(self) -> None:
        """Bring the in-memory layers in line with the files (other editors, rebuilds)."""
        stamp = self._watched_stamp()
        if stamp != self._stamp:
            for p in self._watched:
                layer = Sdf.Layer.Find(str(p))
                if layer is not None:
                    layer.Reload(force=True)
            self._stamp = stamp
            self._on_reload()
        for stale in self.path.parent.glob(f".{self.path.name}.*.tmp"):
            with contextlib.suppress(OSError):
                stale.unlink()  # a writer that died mid-save (we hold the lock)
        try:
            data = self.path.read_bytes()
        except OSError as exc:
            raise AuthoringError(
                f"{self.path}: cannot read the edits layer ({exc.strerror}); rebuild the world"
            ) from exc
        if data != self._synced:
            if self.layer.ExportToString().encode("utf-8") != data:
                try:
                    self.layer.ImportFromString(data.decode("utf-8"))
                except (Tf.ErrorException, UnicodeDecodeError) as exc:
                    raise AuthoringError(
                        f"{self.path}: not a readable usda layer; restore it from a backup, or write "
                        "'#usda 1.0' into it to drop all edits"
                    ) from exc
            self._synced = data

    @contextlib.contextmanager
    def locked(self) -> Iterator[None]:
        """Hold the lock with the layer synced; on an exception, roll the layer back to the file."""
        with edit_lock(self.lock_path):
            self.sync()
            try:
                yield
            except BaseException:
                if self.layer.ExportToString().encode("utf-8") != self._synced:
                    self.layer.ImportFromString((self._synced or b"#usda 1.0\n").decode("utf-8"))
                raise

    def save(self) -> None:
        """Write the layer atomically (call under :meth:`locked`).

        Raises:
            AuthoringError: the file cannot be written; the file on disk is unchanged.
        """
        text = self.layer.ExportToString()
        try:
            atomic_write_text(self.path, text)
        except OutputError as exc:
            cause = exc.__cause__
            reason = cause.strerror if isinstance(cause, OSError) and cause.strerror else str(exc)
            raise AuthoringError(
                f"{self.path}: cannot save the edits ({reason}); nothing was changed"
            ) from exc
        self._synced = text.encode("utf-8")
