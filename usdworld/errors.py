"""The one exception tree of usdworld.

Every error a user can cause derives from :class:`UsdWorldError`. Messages say
where, what and how to fix it, on one line, e.g.
``camera.json -> intrinsic -> fx: must be > 0, got -3.0``.
The CLI prints ``error: <message>`` and exits with :attr:`UsdWorldError.exit_code`.
"""

from __future__ import annotations


class UsdWorldError(Exception):
    """Base class of every error usdworld raises on purpose."""

    exit_code: int = 2


class InputError(UsdWorldError):
    """An input file or argument is missing, unreadable or inconsistent."""


class CalibrationError(UsdWorldError):
    """Camera or ground-plane calibration cannot be determined from the input."""


class LayoutError(UsdWorldError):
    """Objects cannot be placed (e.g. no ground under the camera)."""


class AuthoringError(UsdWorldError):
    """A USD stage cannot be written or read back."""


class OutputError(UsdWorldError):
    """The output location cannot be written."""


class ValidationFailed(UsdWorldError):
    """A written stage failed validation."""

    exit_code = 1


class FramesFailed(UsdWorldError):
    """Some frames of a batch failed (their records in ``batch.json`` say why)."""

    exit_code = 1


class ClusterError(UsdWorldError):
    """The Dask cluster cannot be reached or its workers cannot run the batch."""
