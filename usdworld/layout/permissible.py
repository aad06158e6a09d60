"""Permissible edits (paper step 4): may this object stand there, at this size, as this class?

Pure numpy over a table of ground footprints; the rules the editor applies before it
writes anything:

* **fit** -- the object's footprint (a rectangle ``length x width`` rotated by its yaw)
  must not overlap any other object's footprint by more than :data:`OVERLAP_TOLERANCE_M`.
  Axis-aligned boxes first; where those overlap, the exact rotated rectangles (separating
  axis test), so a diagonal neighbour whose box overlaps but whose shape does not is fine;
* **extent** -- the footprint must lie inside the scene's ground extent;
* **surface** -- the ground under the object's origin (road, sidewalk or other) must be one
  the class may stand on (``usdworld/data/surface_rules.json``);
* **class** -- a replacement must stay within a group of interchangeable classes
  (``usdworld/data/replacement_rules.json``).

Both tables are plain JSON a user can copy and change; point usdworld at the copy with
``--surface-rules`` / ``--replacement-rules`` or the environment variables
:data:`SURFACE_RULES_ENV` / :data:`REPLACEMENT_RULES_ENV`.

The size of a new or replacing object comes from :func:`neighbour_scale`: the median
uniform scale of the nearest objects of the same class (aspect ratio never changes).

Example::

    rules = load_surface_rules()
    others = Footprints(("car_0001",), ("car",), np.array([[10.0, 0.0]]), np.array([[4.2, 1.8]]), np.zeros(1))
    violations = check_placement(Candidate("car", np.array([11.0, 0.5]), np.array([4.2, 1.8]), 0.0),
                                 others, ground, rules)
    # [Violation(rule='fit', message='overlaps car_0001 by 1.30 m')]
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

import numpy as np

from usdworld.errors import InputError
from usdworld.layout.collision import TOLERANCE_M, footprint_half_extents
from usdworld.resources import data_dir

#: Footprints may overlap by at most this much (metres), as in collision resolution.
OVERLAP_TOLERANCE_M = TOLERANCE_M
#: Ground surfaces a point can be on; ``other`` is any ground that is neither mesh.
SURFACES = ("road", "sidewalk", "other")
#: Environment variables naming a user's own rule tables.
SURFACE_RULES_ENV = "USDWORLD_SURFACE_RULES"
REPLACEMENT_RULES_ENV = "USDWORLD_REPLACEMENT_RULES"
#: Default rule tables (in ``usdworld/data``).
SURFACE_RULES_FILE = "surface_rules.json"
REPLACEMENT_RULES_FILE = "replacement_rules.json"
#: Number of same-class neighbours whose median scale sizes a new object.
NEIGHBOURS = 3
#: Margin around the objects' footprints that makes the ground extent of a world
#: without ground meshes (built from detections only), metres.
NO_MESH_MARGIN_M = 5.0
#: Normal z-component above which a ground-mesh face counts as a top face.
_TOP_NORMAL_Z = 0.9
#: Barycentric slack of the point-in-triangle test (shared edges belong to both faces).
_EDGE_EPS = 1e-9


# --- footprints -----------------------------------------------------------------------


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=np.float64)
    a.flags.writeable = False
    return a


@dataclass(frozen=True)
class Footprints:
    """Ground footprints of the objects an edit must respect.

    Attributes:
        names: object names, e.g. ``car_0003``.
        classes: class of each object.
        centers: (N, 2) float64 footprint centres (the object origins) on the ground, metres.
        size_lw: (N, 2) float64 scaled length (object forward, +X of the asset) and width.
        yaw: (N,) float64 rotation about Z, radians.
        scale: (N,) float64 uniform scale of each object (1 where unknown).
    """

    names: tuple[str, ...]
    classes: tuple[str, ...]
    centers: np.ndarray
    size_lw: np.ndarray
    yaw: np.ndarray
    scale: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __post_init__(self) -> None:
        n = len(self.names)
        scale = self.scale if len(self.scale) == n else np.ones(n)
        object.__setattr__(self, "centers", _frozen(np.asarray(self.centers, dtype=np.float64).reshape(n, 2)))
        object.__setattr__(self, "size_lw", _frozen(np.asarray(self.size_lw, dtype=np.float64).reshape(n, 2)))
        object.__setattr__(self, "yaw", _frozen(np.asarray(self.yaw, dtype=np.float64).reshape(n)))
        object.__setattr__(self, "scale", _frozen(np.asarray(scale, dtype=np.float64).reshape(n)))
        if len(self.classes) != n:
            raise ValueError(f"Footprints: {n} names but {len(self.classes)} classes")
        if not (
            np.all(np.isfinite(self.centers)) and np.all(self.size_lw > 0) and np.all(np.isfinite(self.yaw))
        ):
            raise ValueError("Footprints: centres and yaws must be finite and sizes > 0")

    def __len__(self) -> int:
        return len(self.names)

    def without(self, *names: str) -> Footprints:
        """The same table without the named objects."""
        keep = np.array([n not in names for n in self.names], dtype=bool)
        return Footprints(
            tuple(n for n, k in zip(self.names, keep) if k),
            tuple(c for c, k in zip(self.classes, keep) if k),
            self.centers[keep],
            self.size_lw[keep],
            self.yaw[keep],
            self.scale[keep],
        )


@dataclass(frozen=True)
class Candidate:
    """An object where an edit would put it.

    Attributes:
        class_name: its class.
        center: (2,) float64 footprint centre on the ground, metres.
        size_lw: (2,) float64 scaled length and width, metres.
        yaw: rotation about Z, radians.
    """

    class_name: str
    center: np.ndarray
    size_lw: np.ndarray
    yaw: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _frozen(np.asarray(self.center, dtype=np.float64).reshape(2)))
        object.__setattr__(self, "size_lw", _frozen(np.asarray(self.size_lw, dtype=np.float64).reshape(2)))
        if not (np.all(np.isfinite(self.center)) and np.all(self.size_lw > 0) and np.isfinite(self.yaw)):
            raise InputError(f"{self.class_name}: position must be finite and size > 0")


@dataclass(frozen=True)
class Violation:
    """One rule an edit breaks.

    Attributes:
        rule: ``fit``, ``extent``, ``surface`` or ``class``.
        message: why, e.g. ``overlaps car_0005 by 0.80 m``.
        other: the object it concerns (``fit``: the one overlapped), '' when none.
        amount_m: by how much (``fit``: the overlap, ``extent``: the distance outside),
            metres; 0 for ``surface`` and ``class``.
    """

    rule: str
    message: str
    other: str = ""
    amount_m: float = 0.0

    def __str__(self) -> str:
        return f"{self.rule}: {self.message}"


def rectangle_corners(center: np.ndarray, size_lw: np.ndarray, yaw: float) -> np.ndarray:
    """Corners of a rotated rectangle, counter-clockwise.

    Args:
        center: (2,) float64 centre.
        size_lw: (2,) float64 length (along the yaw direction) and width.
        yaw: rotation about Z, radians.

    Returns:
        (4, 2) float64 corners.
    """
    c, s = np.cos(yaw), np.sin(yaw)
    hl, hw = 0.5 * np.asarray(size_lw, dtype=np.float64)
    local = np.array([[hl, -hw], [hl, hw], [-hl, hw], [-hl, -hw]])
    rot = np.array([[c, -s], [s, c]])
    return local @ rot.T + np.asarray(center, dtype=np.float64)


def penetration_depth(a: np.ndarray, b: np.ndarray) -> float:
    """How far two convex quadrilaterals overlap (separating axis theorem).

    Args:
        a: (4, 2) float64 corners of the first rectangle, in order.
        b: (4, 2) float64 corners of the second.

    Returns:
        The smallest overlap of their projections over the edge normals of both, metres:
        the distance one must move to separate them. <= 0 when they do not overlap
        (minus the gap along the best separating axis).
    """
    edges = np.concatenate([np.roll(a, -1, axis=0) - a, np.roll(b, -1, axis=0) - b])
    axes = np.column_stack([-edges[:, 1], edges[:, 0]])
    axes /= np.maximum(np.linalg.norm(axes, axis=1, keepdims=True), 1e-12)
    pa, pb = a @ axes.T, b @ axes.T  # (4, 8)
    overlap = np.minimum(pa.max(axis=0), pb.max(axis=0)) - np.maximum(pa.min(axis=0), pb.min(axis=0))
    return float(overlap.min())


def overlapping(
    candidate: Candidate, others: Footprints, tol: float = OVERLAP_TOLERANCE_M
) -> list[tuple[str, float]]:
    """Objects whose footprint the candidate overlaps, with the overlap depth.

    Axis-aligned boxes are compared first; only where they overlap are the exact
    rotated rectangles tested.

    Args:
        candidate: the object to place.
        others: every other object's footprint.
        tol: overlap allowed, metres.

    Returns:
        (name, depth in metres) for each overlap deeper than ``tol``, deepest first.
    """
    if len(others) == 0:
        return []
    h = footprint_half_extents(candidate.size_lw[None, :], np.array([candidate.yaw]))[0]
    oh = footprint_half_extents(others.size_lw, others.yaw)
    gap = np.abs(others.centers - candidate.center) - (oh + h)
    hits = np.nonzero(np.all(gap < -tol, axis=1))[0]
    corners = rectangle_corners(candidate.center, candidate.size_lw, candidate.yaw)
    out = []
    for i in hits:
        depth = penetration_depth(
            corners, rectangle_corners(others.centers[i], others.size_lw[i], others.yaw[i])
        )
        if depth > tol:
            out.append((others.names[i], depth))
    return sorted(out, key=lambda item: (-item[1], item[0]))


def footprint_overlaps(objects: Footprints, tol: float = OVERLAP_TOLERANCE_M) -> list[tuple[str, str, float]]:
    """Every pair of objects whose footprints overlap by more than ``tol``.

    Returns:
        (name_i, name_j, depth) with i before j in the table.
    """
    out: list[tuple[str, str, float]] = []
    for i in range(len(objects)):
        cand = Candidate(objects.classes[i], objects.centers[i], objects.size_lw[i], float(objects.yaw[i]))
        rest = Footprints(
            objects.names[i + 1 :],
            objects.classes[i + 1 :],
            objects.centers[i + 1 :],
            objects.size_lw[i + 1 :],
            objects.yaw[i + 1 :],
            objects.scale[i + 1 :],
        )
        out.extend((objects.names[i], name, depth) for name, depth in overlapping(cand, rest, tol))
    return out


# --- ground ---------------------------------------------------------------------------


@dataclass(frozen=True)
class Ground:
    """The ground an object can stand on.

    Attributes:
        triangles: surface name (``road``, ``sidewalk``) -> (T, 3, 3) float64 top-face
            triangles in the world frame.
        extent: (2, 2) float64 ``[[xmin, ymin], [xmax, ymax]]`` of the usable ground.
    """

    triangles: Mapping[str, np.ndarray]
    extent: np.ndarray

    def __post_init__(self) -> None:
        tris = {
            k: _frozen(np.asarray(v, dtype=np.float64).reshape(-1, 3, 3)) for k, v in self.triangles.items()
        }
        unknown = sorted(set(tris) - set(SURFACES))
        if unknown:
            raise ValueError(f"Ground: unknown surfaces {unknown}; use {SURFACES[:2]}")
        object.__setattr__(self, "triangles", MappingProxyType(tris))
        object.__setattr__(self, "extent", _frozen(np.asarray(self.extent, dtype=np.float64).reshape(2, 2)))

    @property
    def has_meshes(self) -> bool:
        """True when any surface has triangles (surfaces are known)."""
        return any(len(t) for t in self.triangles.values())


def top_faces(points_world: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """The upward-facing triangles of a ground mesh.

    Args:
        points_world: (V, 3) float64 vertices.
        faces: (F, 3) int triangles, counter-clockwise seen from outside.

    Returns:
        (T, 3, 3) float64 triangles whose normal is within ~25 degrees of +Z.
    """
    tris = np.asarray(points_world, dtype=np.float64)[np.asarray(faces, dtype=np.int64)]
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    norm = np.linalg.norm(n, axis=1)
    keep = (norm > 1e-12) & (n[:, 2] > _TOP_NORMAL_Z * np.maximum(norm, 1e-12))
    return tris[keep]


def make_ground(
    triangles: Mapping[str, np.ndarray],
    fallback_bounds: np.ndarray | None = None,
    placed_bounds: np.ndarray | None = None,
) -> Ground:
    """A :class:`Ground` whose extent is the union of the surfaces' bounds (and of the
    footprints the build placed).

    Args:
        triangles: surface name -> (T, 3, 3) float64 top faces.
        fallback_bounds: (2, 2) float64 extent to use when there is no ground mesh (e.g.
            the bounds of the objects' footprints, padded by :data:`NO_MESH_MARGIN_M`).
        placed_bounds: (2, 2) float64 bounds of the footprints of the objects the build
            placed, added to the meshes' extent (buildings stand beyond the sidewalks).

    Raises:
        InputError: no triangles and no fallback.
    """
    pts = [np.asarray(t, dtype=np.float64).reshape(-1, 3)[:, :2] for t in triangles.values() if len(t)]
    if pts:
        allp = np.concatenate(pts)
        extent = np.array([allp.min(axis=0), allp.max(axis=0)])
        if placed_bounds is not None:
            b = np.asarray(placed_bounds, dtype=np.float64).reshape(2, 2)
            extent = np.array([np.minimum(extent[0], b[0]), np.maximum(extent[1], b[1])])
    elif fallback_bounds is not None:
        extent = np.asarray(fallback_bounds, dtype=np.float64).reshape(2, 2)
    else:
        raise InputError(
            "the world has no ground meshes and no objects: there is no ground to place anything on"
        )
    return Ground(dict(triangles), extent)


def _point_in_triangles(p: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """(N, T) bool: point i lies in triangle j (x, y only)."""
    a, b, c = tris[:, 0, :2], tris[:, 1, :2], tris[:, 2, :2]
    v0, v1 = c - a, b - a  # (T, 2)
    v2 = p[:, None, :] - a[None, :, :]  # (N, T, 2)
    d00, d01, d11 = (v0 * v0).sum(1), (v0 * v1).sum(1), (v1 * v1).sum(1)
    d02, d12 = (v2 * v0).sum(2), (v2 * v1).sum(2)
    den = d00 * d11 - d01 * d01
    ok = np.abs(den) > 1e-18
    den = np.where(ok, den, 1.0)
    u = (d11 * d02 - d01 * d12) / den
    v = (d00 * d12 - d01 * d02) / den
    return ok & (u >= -_EDGE_EPS) & (v >= -_EDGE_EPS) & (u + v <= 1 + _EDGE_EPS)


def surface_at(points_ground: np.ndarray, ground: Ground) -> tuple[list[str], np.ndarray]:
    """Which surface each ground point is on, and the ground height there.

    Args:
        points_ground: (N, 2) float64 points (x, y), metres.
        ground: the world's ground.

    Returns:
        The surface name of each point (``road``, ``sidewalk`` or ``other``) and (N,)
        float64 heights of the surface's top there (0 on ``other``).
    """
    p = np.asarray(points_ground, dtype=np.float64).reshape(-1, 2)
    names = ["other"] * len(p)
    z = np.zeros(len(p))
    done = np.zeros(len(p), dtype=bool)
    for name in SURFACES[:2]:
        tris = ground.triangles.get(name)
        if tris is None or len(tris) == 0 or done.all():
            continue
        lo, hi = tris[:, :, :2].min(axis=1), tris[:, :, :2].max(axis=1)
        for i in np.nonzero(~done)[0]:
            near = np.nonzero(np.all((p[i] >= lo - 1e-9) & (p[i] <= hi + 1e-9), axis=1))[0]
            if len(near) == 0:
                continue
            inside = _point_in_triangles(p[i : i + 1], tris[near])[0]
            if inside.any():
                names[i] = name
                z[i] = float(tris[near[np.argmax(inside)]][:, 2].mean())
                done[i] = True
    return names, z


# --- rule tables ----------------------------------------------------------------------


def _rules_path(explicit: Path | str | None, env: str, default_name: str) -> Path:
    if explicit is not None:
        return Path(explicit)
    if os.environ.get(env):
        return Path(os.environ[env])
    return data_dir() / default_name


def _read_json(path: Path, option: str, env: str) -> dict:
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError as exc:
        raise InputError(f"{path}: no such rule file; fix {option} or ${env}") from exc
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{path}: not a readable JSON rule table ({exc}); fix the file or {option}") from exc
    if not isinstance(doc, dict):
        raise InputError(f"{path}: must hold a JSON object, got {type(doc).__name__}")
    return doc


@dataclass(frozen=True)
class SurfaceRules:
    """Where each class may stand.

    Attributes:
        allowed: class -> surfaces it may stand on.
        default: surfaces for classes the table does not name.
        source: the file the rules came from (named in refusals).
    """

    allowed: Mapping[str, tuple[str, ...]]
    default: tuple[str, ...]
    source: str

    def for_class(self, class_name: str) -> tuple[str, ...]:
        """Surfaces ``class_name`` may stand on."""
        return self.allowed.get(class_name, self.default)


def _surface_list(value: object, where: str) -> tuple[str, ...]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise InputError(f"{where}: must be a list of surface names from {list(SURFACES)}")
    bad = [v for v in value if v not in SURFACES]
    if bad:
        raise InputError(f"{where}: unknown surface(s) {bad}; use {list(SURFACES)}")
    return tuple(value)


def load_surface_rules(path: Path | str | None = None) -> SurfaceRules:
    """Read the surface rule table.

    Args:
        path: a user's table; default ``$USDWORLD_SURFACE_RULES``, else the shipped one.

    Format: ``{"_default": ["road", "sidewalk", "other"], "car": ["road"], ...}``; keys
    starting with ``_`` other than ``_default`` are comments.

    Raises:
        InputError: unreadable file or unknown surface names.
    """
    src = _rules_path(path, SURFACE_RULES_ENV, SURFACE_RULES_FILE)
    doc = _read_json(src, "--surface-rules", SURFACE_RULES_ENV)
    default = _surface_list(doc.get("_default", list(SURFACES)), f"{src} -> _default")
    allowed = {k: _surface_list(v, f"{src} -> {k}") for k, v in doc.items() if not k.startswith("_")}
    return SurfaceRules(MappingProxyType(allowed), default, str(src))


@dataclass(frozen=True)
class ReplacementRules:
    """Which classes may replace which: groups of interchangeable classes.

    Attributes:
        groups: group name -> member classes.
        source: the file the rules came from.
    """

    groups: Mapping[str, tuple[str, ...]]
    source: str

    def alternatives(self, class_name: str) -> list[str]:
        """Classes that may replace ``class_name`` (itself included), sorted."""
        out = {class_name}
        for members in self.groups.values():
            if class_name in members:
                out.update(members)
        return sorted(out)

    def allows(self, old: str, new: str) -> bool:
        """True when an object of class ``old`` may be replaced by one of class ``new``."""
        return new in self.alternatives(old)


def load_replacement_rules(path: Path | str | None = None) -> ReplacementRules:
    """Read the replacement rule table.

    Args:
        path: a user's table; default ``$USDWORLD_REPLACEMENT_RULES``, else the shipped one.

    Format: ``{"groups": {"vehicles": ["car", "truck", "bus"], ...}}``; any two classes of
    one group may replace each other, and a class may always be replaced by itself
    (another variant).

    Raises:
        InputError: unreadable file or a malformed group.
    """
    src = _rules_path(path, REPLACEMENT_RULES_ENV, REPLACEMENT_RULES_FILE)
    doc = _read_json(src, "--replacement-rules", REPLACEMENT_RULES_ENV)
    groups = doc.get("groups")
    if not isinstance(groups, dict):
        raise InputError(f'{src}: needs "groups": {{"name": ["class", ...], ...}}')
    out = {}
    for name, members in groups.items():
        if not isinstance(members, list) or not all(isinstance(m, str) and m for m in members):
            raise InputError(f"{src} -> groups -> {name}: must be a list of class names")
        out[name] = tuple(members)
    return ReplacementRules(MappingProxyType(out), str(src))


# --- rules ----------------------------------------------------------------------------


def fit_violations(candidate: Candidate, others: Footprints) -> list[Violation]:
    """``fit``: one violation per object the candidate overlaps."""
    return [
        Violation("fit", f"overlaps {name} by {depth:.2f} m", name, float(depth))
        for name, depth in overlapping(candidate, others)
    ]


def extent_violations(candidate: Candidate, ground: Ground) -> list[Violation]:
    """``extent``: the footprint must lie inside the ground extent."""
    corners = rectangle_corners(candidate.center, candidate.size_lw, candidate.yaw)
    lo, hi = ground.extent
    out_lo = np.maximum(lo - corners.min(axis=0), 0.0)
    out_hi = np.maximum(corners.max(axis=0) - hi, 0.0)
    worst = float(max(out_lo.max(), out_hi.max()))
    if worst <= OVERLAP_TOLERANCE_M:
        return []
    return [
        Violation(
            "extent",
            f"footprint reaches {worst:.2f} m outside the ground extent "
            f"x {lo[0]:.1f}..{hi[0]:.1f}, y {lo[1]:.1f}..{hi[1]:.1f} m",
            amount_m=worst,
        )
    ]


def surface_violations(class_name: str, surface: str, rules: SurfaceRules) -> list[Violation]:
    """``surface``: the class may stand on the surface under its origin."""
    allowed = rules.for_class(class_name)
    if surface in allowed:
        return []
    return [
        Violation(
            "surface",
            f"{class_name} may stand on {' or '.join(allowed)}, not {surface} (rules: {rules.source})",
        )
    ]


def replacement_violations(old: str, new: str, rules: ReplacementRules) -> list[Violation]:
    """``class``: ``new`` may replace ``old``."""
    if rules.allows(old, new):
        return []
    return [
        Violation(
            "class",
            f"{old} may be replaced by {', '.join(rules.alternatives(old))}, not {new} "
            f"(rules: {rules.source})",
        )
    ]


def check_placement(
    candidate: Candidate, others: Footprints, ground: Ground, rules: SurfaceRules, *, surface: bool = True
) -> list[Violation]:
    """Every rule a placed (added, moved, rotated or replacing) object breaks.

    Args:
        candidate: the object where it would stand.
        others: every other active object.
        ground: the world's ground.
        rules: the surface rule table.
        surface: also check the surface rule (off for a pure rotation, which keeps the origin).

    Returns:
        The violations, fit first; empty when the edit is permissible. The surface rule
        is skipped on a ground without meshes (e.g. a world built from detections only),
        where no point's surface is known.
    """
    out = fit_violations(candidate, others) + extent_violations(candidate, ground)
    if surface and ground.has_meshes:
        names, _ = surface_at(candidate.center[None, :], ground)
        out += surface_violations(candidate.class_name, names[0], rules)
    return out


def neighbour_scale(
    class_name: str,
    center: np.ndarray,
    objects: Footprints,
    scale_range: tuple[float, float],
    fallback: float = 1.0,
    k: int = NEIGHBOURS,
) -> float:
    """Uniform scale for an object of ``class_name`` at ``center``, from its neighbours.

    Args:
        class_name: class of the new object.
        center: (2,) float64 where it will stand.
        objects: the other objects (with their scales).
        scale_range: (min, max) scale allowed for the class.
        fallback: scale when no object of the class exists (e.g. the scale of the object
            being replaced).
        k: how many nearest same-class objects to take the median of.

    Returns:
        The median scale of the ``k`` nearest objects of the same class, or ``fallback``,
        clamped to ``scale_range``.
    """
    idx = [i for i, c in enumerate(objects.classes) if c == class_name]
    if idx:
        d = np.linalg.norm(objects.centers[idx] - np.asarray(center, dtype=np.float64).reshape(1, 2), axis=1)
        nearest = np.asarray(idx)[np.argsort(d, kind="stable")[:k]]
        value = float(np.median(objects.scale[nearest]))
    else:
        value = float(fallback)
    return float(np.clip(value, scale_range[0], scale_range[1]))
