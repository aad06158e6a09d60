"""Tuned numbers of writing a world's layers (:mod:`usdworld.authoring.world`).

A section of its own, not a field of :class:`~usdworld.parameters.Parameters`, so that the
build's ``report.json`` (which records every section) stays as it was: what these numbers
choose is visible in the world itself (the root layer's sublayers name the base layer).
"""

from __future__ import annotations

from dataclasses import dataclass

from usdworld.parameters.base import param


@dataclass(frozen=True)
class AuthoringParams:
    """How a world's layers are written; each field documents its unit, meaning and origin."""

    large_world_min_objects: int = param(
        1000,
        "count",
        "A world with at least this many objects is written for its size: its base layer in USD's "
        "binary crate format (`layers/base.usdc`; smaller worlds keep the text `layers/base.usda`, "
        "readable and diffable; the root and the edits layer are text either way), and the objects' "
        "opinions in the base layers kept in `layers/objects.index.npz` for the editor.",
        "tuned: tools/bench_scale.py (synthetic seed-3 frame tiled, 50 to 10,000 objects, session 10): "
        "parsing the text layer costs about 50 us of CPU per object against 14 us for the crate; at "
        "1,000 objects the text layer is 1.7 MB and its parse 2.2x the crate's (56 against 25 ms); at "
        "50 objects both take 13-19 ms",
    )

    def __post_init__(self) -> None:
        n = self.large_world_min_objects
        if int(n) != n or n < 0:
            raise ValueError(f"authoring.large_world_min_objects must be a whole number >= 0, got {n}")
