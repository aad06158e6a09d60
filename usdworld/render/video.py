"""H.264 MP4 writing (browser-playable) and reading back, through imageio-ffmpeg.

Videos are H.264 (libx264), ``yuv420p`` and ``+faststart`` (the ``moov`` index before the
media data, so a browser starts playing before the download ends); that needs even image
dimensions, which :class:`Mp4Writer` checks instead of letting ffmpeg rescale. The file is
written under a temporary name in the same folder and renamed at the end, so an existing
video is never left half-written.

Frames go through a bounded queue to a thread that pipes them into ffmpeg's stdin (raw RGB),
so the caller renders the next frames while ffmpeg encodes: :meth:`Mp4Writer.write` returns
as soon as the frame is queued, and waits only when :data:`QUEUE_FRAMES` frames are pending.

Example:
    >>> with Mp4Writer("fly.mp4", 960, 480, fps=30) as video:     # doctest: +SKIP
    ...     for frame in frames:                                   # (480, 960, 3) uint8 RGB
    ...         video.write(frame)
"""

from __future__ import annotations

import logging
import os
import queue
import tempfile
import threading
from collections.abc import Generator
from pathlib import Path
from typing import Any, Self

import numpy as np

from usdworld.errors import InputError, OutputError, UsdWorldError
from usdworld.parameters.video import VideoParams

log = logging.getLogger(__name__)

#: What :class:`Mp4Writer` takes -> ffmpeg's input pixel format.
SOURCES = {"rgb24": "rgb24", "rgba_bottom_up": "rgba"}

#: Frames queued for the encoder at most (memory: this many frames, e.g. 2.4 MB each at 1280x640).
QUEUE_FRAMES = 8


def _ffmpeg() -> Any:
    try:
        import imageio_ffmpeg
    except ImportError as exc:
        raise UsdWorldError(
            f"writing MP4 needs the Python package imageio-ffmpeg ({exc}); run: pip install 'imageio-ffmpeg>=0.5'"
        ) from None
    return imageio_ffmpeg


def check_video_size(width: int, height: int) -> None:
    """Raise InputError unless both sides are even and positive (H.264 yuv420p needs it)."""
    if width <= 0 or height <= 0 or width % 2 or height % 2:
        raise InputError(
            f"video size must be even and positive for H.264 yuv420p, got {width}x{height}; pass e.g. --size 960x480"
        )


class Mp4Writer:
    """Stream RGB frames into an H.264 MP4 file; use as a context manager.

    Args:
        path: the ``.mp4`` file to write (replaced atomically on success).
        width: frame width in pixels (even).
        height: frame height in pixels (even).
        fps: frames per second.
        params: the encoder's settings (default :class:`~usdworld.parameters.video.VideoParams`).
        source: what :meth:`write` takes: ``"rgb24"``, (height, width, 3) uint8 RGB arrays, rows top
            first; or ``"rgba_bottom_up"``, GL's readback as is (``Renderer.render_rgba_rows``:
            height * width * 4 RGBA bytes, rows bottom first), which ffmpeg flips (``-vf vflip``, no
            copy) and converts: the same file, byte for byte, as the RGB frames give.

    Raises:
        InputError: odd or non-positive size, or fps <= 0.
        OutputError: the folder cannot be written.
    """

    def __init__(
        self,
        path: str | Path,
        width: int,
        height: int,
        fps: float = 30.0,
        params: VideoParams | None = None,
        source: str = "rgb24",
    ) -> None:
        check_video_size(width, height)
        if not fps > 0:
            raise InputError(f"fps must be > 0, got {fps}")
        if source not in SOURCES:
            raise UsdWorldError(f"Mp4Writer source must be one of {', '.join(SOURCES)}, got {source!r}")
        self.source = source
        self.path = Path(path)
        self.width, self.height, self.fps = int(width), int(height), float(fps)
        self.params = params or VideoParams()
        self.frames_written = 0
        folder = self.path.parent
        try:
            folder.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=f".{self.path.stem}.", suffix=".mp4", dir=folder)
            os.close(fd)
        except OSError as exc:
            raise OutputError(
                f"{self.path}: cannot write there ({exc.strerror}); choose another -o"
            ) from None
        self._tmp = Path(tmp)
        try:
            self._gen: Generator[None, Any, None] | None = _ffmpeg().write_frames(
                str(self._tmp),
                (self.width, self.height),
                pix_fmt_in=SOURCES[source],
                pix_fmt_out="yuv420p",
                fps=self.fps,
                quality=None,
                codec="libx264",
                macro_block_size=1,
                ffmpeg_log_level="error",
                output_params=[
                    *(["-vf", "vflip"] if source == "rgba_bottom_up" else []),
                    *self.params.x264_arguments(),
                    "-movflags",
                    "+faststart",
                ],
            )
            self._gen.send(None)  # start ffmpeg
        except UsdWorldError:
            self._tmp.unlink(missing_ok=True)
            raise
        except Exception as exc:  # noqa: BLE001  (imageio-ffmpeg raises plain errors)
            self._tmp.unlink(missing_ok=True)
            raise OutputError(
                f"{self.path}: ffmpeg (libx264) could not start: {' '.join(str(exc).split())}"
            ) from None
        self._queue: queue.Queue[np.ndarray | bytes | None] = queue.Queue(maxsize=QUEUE_FRAMES)
        self._failure: str | None = None
        self._thread = threading.Thread(target=self._feed, name="mp4-writer", daemon=True)
        self._thread.start()

    def _feed(self) -> None:
        """The writer thread: queued frames into ffmpeg until the end mark (None)."""
        while (frame := self._queue.get()) is not None:
            if self._failure is not None:
                continue  # ffmpeg is gone: drain the queue so that write() never blocks
            try:
                self._gen.send(frame)  # type: ignore[union-attr]
            except Exception as exc:  # noqa: BLE001  (ffmpeg died: disk full, killed ...)
                self._failure = " ".join(str(exc).split())

    def _stop_thread(self) -> None:
        self._queue.put(None)
        self._thread.join()

    def _raise_failure(self) -> None:
        failure = self._failure
        self.abort()
        raise OutputError(f"{self.path}: ffmpeg stopped while writing: {failure}")

    def write(self, frame_rgb: np.ndarray | bytes) -> None:
        """Queue one frame for encoding (a copy: the caller may reuse its array).

        Args:
            frame_rgb: (height, width, 3) uint8 RGB; with ``source="rgba_bottom_up"``, the RGBA
                bytes, rows bottom first.

        Raises:
            OutputError: ffmpeg stopped (the partial file is deleted).
        """
        if self._gen is None:
            raise UsdWorldError("this Mp4Writer is closed")
        if self.source == "rgba_bottom_up":
            self._write_rows(frame_rgb)
            return
        frame = np.asarray(frame_rgb)
        if frame.shape != (self.height, self.width, 3) or frame.dtype != np.uint8:
            raise UsdWorldError(
                f"video frame must be ({self.height}, {self.width}, 3) uint8, got {frame.shape} {frame.dtype}"
            )
        if self._failure is not None:
            self._raise_failure()
        self._queue.put(np.array(frame, order="C", copy=True))
        self.frames_written += 1

    def _write_rows(self, rows: bytes) -> None:
        """Queue GL's RGBA rows (bytes are immutable: no copy)."""
        if not isinstance(rows, bytes) or len(rows) != self.width * self.height * 4:
            got = len(rows) if isinstance(rows, bytes) else type(rows).__name__
            size = self.width * self.height * 4
            raise UsdWorldError(f"video frame must be {size} RGBA bytes (rows bottom first), got {got}")
        if self._failure is not None:
            self._raise_failure()
        self._queue.put(rows)
        self.frames_written += 1

    def close(self) -> Path:
        """Encode what is queued, finish the file and move it into place; returns its path.

        Raises:
            OutputError: ffmpeg stopped (the partial file is deleted).
        """
        if self._gen is not None:
            self._stop_thread()
            if self._failure is not None:
                self._raise_failure()
            gen, self._gen = self._gen, None
            gen.close()
            os.chmod(self._tmp, 0o644)
            os.replace(self._tmp, self.path)
        return self.path

    def abort(self) -> None:
        """Stop ffmpeg and delete the partial file."""
        if self._gen is not None:
            self._failure = self._failure or "aborted"  # the thread drops what is still queued
            self._stop_thread()
            gen, self._gen = self._gen, None
            try:
                gen.close()
            except Exception:
                log.debug("ffmpeg did not close cleanly", exc_info=True)
        self._tmp.unlink(missing_ok=True)

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type: object, *rest: object) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


def read_video_frames(path: str | Path) -> tuple[dict[str, Any], list[np.ndarray]]:
    """Decode a whole video with imageio-ffmpeg's reader (for checks and tests).

    Returns:
        The reader's metadata (``size``, ``fps``, ``codec`` ...) and the frames, each
        (H, W, 3) uint8 RGB.
    """
    reader = _ffmpeg().read_frames(str(path))
    meta = reader.__next__()
    w, h = meta["size"]
    frames = [np.frombuffer(buf, dtype=np.uint8).reshape(h, w, 3) for buf in reader]
    return meta, frames


def moov_before_mdat(path: str | Path) -> bool:
    """True when the MP4's top-level ``moov`` box precedes ``mdat`` (``+faststart``)."""
    data = Path(path).read_bytes()
    pos, order = 0, []
    while pos + 8 <= len(data):
        size = int.from_bytes(data[pos : pos + 4], "big")
        kind = data[pos + 4 : pos + 8].decode("latin-1")
        order.append(kind)
        if size == 1 and pos + 16 <= len(data):
            size = int.from_bytes(data[pos + 8 : pos + 16], "big")
        if size < 8:
            break
        pos += size
    return "moov" in order and "mdat" in order and order.index("moov") < order.index("mdat")
