"""The class table: what each placed class measures and which roles it plays.

``usdworld/data/class_priors.json`` holds, per placed class, its metric size prior and its
*roles*, the behaviour the algorithms give it. The table is read once, at the edge (the
pipeline, the editor, the CLI), and passed into perception and layout, which do no file
I/O of their own.

Roles (``roles`` in the JSON; :data:`ROLES`):

* ``crown``: stuff cut into one object per crown top (trees).
* ``topped``: stuff cut like crowns, by its tops and posts (trees, signs one behind another).
* ``trunk``: stands on a trunk or post: collides and touches the ground by it; its crown,
  arm or plate may hang over ground far behind it.
* ``post``: thin upright stuff whose pieces one above the other, split by what stands in
  front, are one object.
* ``post_contact``: its contact is its lowest columns even where nothing below is ground
  (a pole whose foot is hidden stands below its post, not its lamp's arm).
* ``facade``: cut like facades when the perspective is known, faces the road, sized by
  its frontage (buildings).
* ``line``: forms a row along each side of the street (facades, trees, poles, signs).
* ``thin_occluder``: ground continues behind it (trunks, posts).
* ``unbounding_occluder``: never bounds the depth of what it hides, and is never placed
  by such a bound alone (a facade's bottom edge hides ground and things far behind it).
"""

from __future__ import annotations

import json
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

from usdworld.errors import InputError
from usdworld.resources import data_dir

#: How a class may be oriented (:func:`usdworld.layout.yaw.heading_for`).
YAW_MODES = ("road", "along_road", "face_road", "camera", "none")
#: Roles a class may play (module docstring).
ROLES = frozenset(
    {"crown", "topped", "trunk", "post", "post_contact", "facade", "line", "thin_occluder", "unbounding_occluder"}
)
#: The table shipped with usdworld.
DEFAULT_CLASS_TABLE_FILE = "class_priors.json"


@dataclass(frozen=True)
class ClassPrior:
    """What a class usually measures, and the roles it plays.

    Attributes:
        name: placed class name.
        size_m: (length along the object's forward axis, width, height) in metres.
        height_std_m: spread of real heights, metres.
        scale_range: (min, max) uniform scale allowed relative to ``size_m``.
        yaw: ``road``, ``along_road``, ``face_road``, ``camera`` or ``none``: how the object is oriented
            (:func:`usdworld.layout.yaw.heading_for`).
        kind: ``thing`` or ``stuff``.
        rigid_height: True when the height is reliable enough to calibrate the camera.
        facade_depth_m: for classes that face the road, the footprint's extent behind the
            facade (a photo shows only the front): it replaces the uniform scale's depth.
            None: the uniform scale's.
        frontage_range_m: for classes that face the road, the usual (min, max) frontage
            along the street, which sizes one running out of the image at a side. None:
            no such sizing.
        roles: the roles the class plays (:data:`ROLES`).
    """

    name: str
    size_m: tuple[float, float, float]
    height_std_m: float
    scale_range: tuple[float, float]
    yaw: str
    kind: str
    rigid_height: bool
    facade_depth_m: float | None = None
    frontage_range_m: tuple[float, float] | None = None
    roles: frozenset[str] = frozenset()

    def __post_init__(self) -> None:
        where = f"{DEFAULT_CLASS_TABLE_FILE} -> {self.name}"
        if len(self.size_m) != 3 or any(not s > 0 for s in self.size_m):
            raise InputError(f"{where} -> size_m: must be three sizes > 0 m")
        if len(self.scale_range) != 2 or not 0 < self.scale_range[0] <= 1 <= self.scale_range[1]:
            raise InputError(f"{where} -> scale_range: must be [min, max] with 0 < min <= 1 <= max")
        if self.yaw not in YAW_MODES:
            raise InputError(f"{where} -> yaw: must be one of {', '.join(YAW_MODES)}")
        if self.kind not in ("thing", "stuff"):
            raise InputError(f"{where} -> kind: must be 'thing' or 'stuff'")
        if self.facade_depth_m is not None and not self.facade_depth_m > 0:
            raise InputError(f"{where} -> facade_depth_m: must be > 0")
        if self.frontage_range_m is not None and not 0 < self.frontage_range_m[0] <= self.frontage_range_m[1]:
            raise InputError(f"{where} -> frontage_range_m: must be [min, max] with 0 < min <= max")
        unknown = self.roles - ROLES
        if unknown:
            raise InputError(f"{where} -> roles: unknown {', '.join(sorted(unknown))}; known: {', '.join(sorted(ROLES))}")

    def has(self, role: str) -> bool:
        """True when the class plays ``role`` (one of :data:`ROLES`)."""
        if role not in ROLES:
            raise ValueError(f"unknown role '{role}'")
        return role in self.roles


@dataclass(frozen=True)
class ClassTable(Mapping[str, ClassPrior]):
    """Every placed class's prior, by name; a read-only mapping (picklable).

    Example:
        >>> table = load_class_table()
        >>> sorted(table.with_role("crown"))
        ['tree']
        >>> table["car"].size_m
        (4.2, 1.8, 1.5)
    """

    priors: tuple[ClassPrior, ...]
    _by_name: dict[str, ClassPrior] = field(init=False, repr=False, compare=False, hash=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_by_name", {p.name: p for p in self.priors})

    def __getitem__(self, class_name: str) -> ClassPrior:
        try:
            return self._by_name[class_name]
        except KeyError:
            raise InputError(f"unknown class '{class_name}'; known classes: {', '.join(sorted(self._by_name))}") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._by_name)

    def __len__(self) -> int:
        return len(self._by_name)

    def __contains__(self, class_name: object) -> bool:
        return class_name in self._by_name

    def __hash__(self) -> int:
        return hash(self.priors)

    def with_role(self, role: str) -> frozenset[str]:
        """Names of the classes that play ``role``."""
        if role not in ROLES:
            raise ValueError(f"unknown role '{role}'")
        return frozenset(p.name for p in self.priors if role in p.roles)

    def has(self, class_name: str, role: str) -> bool:
        """True when ``class_name`` is a known class that plays ``role``."""
        return class_name in self._by_name and self._by_name[class_name].has(role)


def _pair(entry: dict, key: str, where: str) -> tuple[float, float] | None:
    if key not in entry:
        return None
    value = entry[key]
    if not isinstance(value, list) or len(value) != 2:
        raise InputError(f"{where} -> {key}: must be a list [min, max]")
    return (float(value[0]), float(value[1]))


def parse_class_table(raw: object, source: str) -> ClassTable:
    """The class table from its parsed JSON (keys starting with ``_`` are comments).

    Raises:
        InputError: a malformed entry, naming the file, class and field.
    """
    if not isinstance(raw, dict):
        raise InputError(f"{source}: must be a JSON object of classes")
    priors = []
    for name, entry in raw.items():
        if name.startswith("_"):
            continue
        where = f"{source} -> {name}"
        try:
            size = tuple(float(v) for v in entry["size_m"])
            priors.append(
                ClassPrior(
                    name=name,
                    size_m=size,  # type: ignore[arg-type]
                    height_std_m=float(entry["height_std_m"]),
                    scale_range=_pair(entry, "scale_range", where),  # type: ignore[arg-type]
                    yaw=str(entry["yaw"]),
                    kind=str(entry["kind"]),
                    rigid_height=bool(entry["rigid_height"]),
                    facade_depth_m=float(entry["facade_depth_m"]) if "facade_depth_m" in entry else None,
                    frontage_range_m=_pair(entry, "frontage_range_m", where),
                    roles=frozenset(str(r) for r in entry.get("roles", ())),
                )
            )
        except KeyError as exc:
            raise InputError(f"{where}: missing field {exc.args[0]}") from None
        except (TypeError, ValueError) as exc:
            raise InputError(f"{where}: malformed entry ({exc})") from None
    return ClassTable(tuple(priors))


def read_class_table(path: Path) -> ClassTable:
    """Read a class table file (the format of ``usdworld/data/class_priors.json``)."""
    try:
        raw = json.loads(Path(path).read_text())
    except OSError as exc:
        raise InputError(f"{path}: cannot read the class table ({exc.strerror})") from None
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not valid JSON ({exc.msg}, line {exc.lineno})") from None
    return parse_class_table(raw, Path(path).name)


@lru_cache(maxsize=1)
def load_class_table() -> ClassTable:
    """The class table shipped with usdworld (read once per process)."""
    return read_class_table(data_dir() / DEFAULT_CLASS_TABLE_FILE)
