"""All tuned numbers: :class:`Parameters`, one field per section (see the package docstring)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

from usdworld.parameters.base import plain, section_rows
from usdworld.parameters.camera import CameraParams
from usdworld.parameters.collision import CollisionParams
from usdworld.parameters.light import LightParams
from usdworld.parameters.perception import PerceptionParams
from usdworld.parameters.placement import PlacementParams
from usdworld.parameters.scene import SceneParams


@dataclass(frozen=True)
class Parameters:
    """All tuned numbers, by stage.

    Attributes:
        perception: objects from masks and boxes, crowns, facades (pixel space).
        camera: camera estimation from objects, the road and vanishing points.
        placement: depth cues, street rows, occlusion order, scale and position.
        collision: footprint collision resolution.
        scene: ground surfaces, range, the DLT grid and what the pipeline derives.
        light: the sun and sky estimated from the photo's shadows and sky.
    """

    perception: PerceptionParams = field(default_factory=PerceptionParams)
    camera: CameraParams = field(default_factory=CameraParams)
    placement: PlacementParams = field(default_factory=PlacementParams)
    collision: CollisionParams = field(default_factory=CollisionParams)
    scene: SceneParams = field(default_factory=SceneParams)
    light: LightParams = field(default_factory=LightParams)

    def sections(self) -> dict[str, object]:
        """The sections by name, in declaration order."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """``{section: {name: value}}``, JSON-ready (what ``report.json`` records)."""
        return {
            name: {row["name"]: plain(row["value"]) for row in section_rows(section)}
            for name, section in self.sections().items()
        }

    def rows(self) -> list[dict[str, Any]]:
        """Every field as a row (section, name, value, unit, origin, doc), for documentation."""
        return [
            {"section": name, **row} for name, section in self.sections().items() for row in section_rows(section)
        ]

    def replace(self, **changes: dict[str, Any]) -> Parameters:
        """A copy with some fields of some sections changed.

        Args:
            **changes: ``section={field: value}``.

        Raises:
            KeyError: an unknown section or field (the message names the known ones).
        """
        sections = self.sections()
        new = {}
        for name, values in changes.items():
            if name not in sections:
                raise KeyError(f"unknown parameter section '{name}'; known: {', '.join(sections)}")
            section = sections[name]
            known = {f.name: f for f in dataclasses.fields(section)}  # type: ignore[arg-type]
            for key in values:
                if key not in known:
                    raise KeyError(f"unknown parameter '{name}.{key}'; known: {', '.join(sorted(known))}")
            new[name] = dataclasses.replace(section, **values)  # type: ignore[type-var]
        return dataclasses.replace(self, **new)


#: The defaults.
DEFAULT_PARAMETERS = Parameters()
