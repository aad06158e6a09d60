"""The one exception tree of usdworld.

Every error a user can cause derives from :class:`UsdWorldError`. Messages say
where, what and how to fix it, on one line, e.g.
``camera.json -> intrinsic -> fx: must be > 0, got -3.0``.
The CLI prints ``error: <message>`` and exits with :attr:`UsdWorldError.exit_code`.
"""

from __future__ import annotations

from enum import StrEnum
from typing import Any


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


class RefusalReason(StrEnum):
    """Why an edit is refused (:attr:`EditRefused.reason`)."""

    NOT_PERMISSIBLE = "not_permissible"  #: rules refuse it; ``violations`` says which
    UNKNOWN_OBJECT = "unknown_object"  #: no such object, or not an object name or path
    DELETED_OBJECT = "deleted_object"  #: the object is deleted (inactive)
    UNKNOWN_CLASS = "unknown_class"  #: no such class in the class table
    UNKNOWN_VARIANT = "unknown_variant"  #: the class's asset has no such variant
    SAME_CLASS = "same_class"  #: a replacement by the object's own class names no variant
    BAD_VALUE = "bad_value"  #: a non-finite or malformed argument (``field`` names it)
    NOT_EDITABLE = "not_editable"  #: the object's asset cannot take this edit
    NOTHING_TO_RESET = "nothing_to_reset"  #: the object has no edits
    NOTHING_TO_UNDO = "nothing_to_undo"  #: fewer recorded edits than asked to undo


class EditRefused(UsdWorldError):
    """An edit of a world is refused; nothing was written.

    The library words :attr:`message` for no audience in particular (no command-line
    flags, no web terms); the CLI (:mod:`usdworld.cli.edit_cmd`) and the web API
    (:mod:`usdworld.serve.app`) word the structured fields for their own users.

    Attributes:
        reason: why (:class:`RefusalReason`).
        message: the neutral one-line message (also ``str(error)``).
        op: the operation (``move``, ``add`` ...).
        subject: the object or class concerned ('' when none).
        field: the argument concerned (``name``, ``to``, ``by``, ``yaw_deg``, ``at``, ``with``,
            ``variant``, ``color``, ``steps``; '' when none).
        value: the value given for ``field`` (None when none).
        choices: the values that would be accepted (known classes, variants), if any.
        violations: for ``not_permissible``, the rules broken
            (:class:`usdworld.layout.permissible.Violation`: ``rule``, ``message``,
            ``other`` object and ``amount_m``).
    """

    def __init__(
        self,
        reason: RefusalReason,
        message: str,
        *,
        op: str = "",
        subject: str = "",
        field: str = "",
        value: object = None,
        choices: tuple[str, ...] = (),
        violations: tuple[Any, ...] = (),
    ) -> None:
        super().__init__(message)
        self.reason, self.message, self.op, self.subject = RefusalReason(reason), message, op, subject
        self.field, self.value, self.choices, self.violations = (
            field,
            value,
            tuple(choices),
            tuple(violations),
        )
