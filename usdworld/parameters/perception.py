"""Tuned numbers of the perception stage (see :mod:`usdworld.parameters.base` for the field conventions)."""

from __future__ import annotations

from dataclasses import dataclass

from usdworld.parameters.base import param  # noqa: F401  (used as fields are added)


@dataclass(frozen=True)
class PerceptionParams:
    """Thresholds of the perception stage; each field documents its unit, meaning and origin."""
