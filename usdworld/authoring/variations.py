"""Scene variations for simulation (``usdworld vary``): many worlds from one, by permissible edits.

Each variation is a small root layer beside its own edits layer::

    OUT/variation_0001.usda        subLayers = [variation_0001.edits.usda, <world>/layers/edits.usda,
                                                <world>/layers/base.usda]  (relative paths)
    OUT/variation_0001.edits.usda  this variation's random edits (overs and defs only)

so every variation shares the world's base and the user's own edits (later edits to the
world show in every variation), and adds its own. The random edits are the editor's
ordinary operations (:class:`~usdworld.authoring.edits.WorldEditor`), so they pass the
same permissibility rules: swap model variants, recolour vehicles and people, remove
cars and people, add parked cars on the road and people on the sidewalk, and move cars
along their heading (within their lane). A variation is a pure function of the world,
the seed and its index: the same call writes the same bytes (the history records no
time). ``usdworld edit OUT/variation_0001.usda ...`` edits one variation further.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pxr import Sdf, UsdGeom

from usdworld.authoring.edits import WorldEditor, atomic_write_text
from usdworld.authoring.stages import world_root
from usdworld.authoring.world import WORLD_PATH
from usdworld.errors import EditRefused, InputError, RefusalReason, UsdWorldError
from usdworld.layout.permissible import surface_at

#: Random edits per variation: inclusive range.
EDITS_PER_VARIATION = (3, 8)
#: Candidates tried for one random edit before another kind is drawn.
ATTEMPTS = 12
#: How far a car may move along its heading, metres.
LANE_MOVE_M = 8.0
#: A parked car's centre lies within this distance of the road's edge, metres.
PARKED_KERB_M = 2.5
#: Paint colours (sRGB) for recolouring.
PALETTE = ("#c03030", "#f2f2f2", "#1a1a1a", "#2a4d8f", "#8a8d91", "#3d6b3d", "#d9b23a", "#6b2d5c", "#e07b22")
VEHICLES = ("car", "truck", "bus", "motorcycle", "bicycle")
PEOPLE = ("person", "rider")
KINDS = ("swap_variant", "recolour", "remove", "add_car", "add_person", "move_in_lane")


@dataclass(frozen=True)
class Variation:
    """One written variation.

    Attributes:
        root: its root layer.
        edits: its edits layer.
        applied: one line per edit made.
    """

    root: Path
    edits: Path
    applied: tuple[str, ...]


def _write_root(root: Path, sublayers: list[str]) -> None:
    layer = Sdf.Layer.CreateAnonymous(".usda")
    for sub in sublayers:
        layer.subLayerPaths.append(sub)
    layer.defaultPrim = WORLD_PATH.strip("/")
    layer.pseudoRoot.SetInfo(UsdGeom.Tokens.upAxis, UsdGeom.Tokens.z)
    layer.pseudoRoot.SetInfo(UsdGeom.Tokens.metersPerUnit, 1.0)
    atomic_write_text(root, layer.ExportToString())


def _surface_point(rng: np.random.Generator, tris: np.ndarray | None) -> np.ndarray | None:
    """A uniformly random point on a set of (T, 3, 3) triangles, or None when there are none."""
    if tris is None or len(tris) == 0:
        return None
    a, b, c = tris[:, 0, :2], tris[:, 1, :2], tris[:, 2, :2]
    area = 0.5 * np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])
    if area.sum() <= 0:
        return None
    i = int(rng.choice(len(tris), p=area / area.sum()))
    r1, r2 = rng.random(2)
    s = math.sqrt(r1)
    return (1 - s) * a[i] + s * (1 - r2) * b[i] + s * r2 * c[i]


def _attempt(editor: WorldEditor, kind: str, rng: np.random.Generator) -> str | None:
    """Try one random edit of ``kind``; its message, or None when no candidate was permissible."""
    live = [o for o in editor.objects() if o.active]
    ground = editor.ground()
    for _ in range(ATTEMPTS):
        try:
            if kind == "swap_variant":
                pool = [o for o in live if len(editor.variants(o.class_name)) > 1]
                if not pool:
                    return None
                o = pool[rng.integers(len(pool))]
                others = [v for v in editor.variants(o.class_name) if v != o.variant]
                return editor.replace(o.name, o.class_name, variant=others[rng.integers(len(others))]).message
            if kind == "recolour":
                pool = [o for o in live if o.class_name in VEHICLES + PEOPLE]
                if not pool:
                    return None
                o = pool[rng.integers(len(pool))]
                return editor.restyle(o.name, PALETTE[rng.integers(len(PALETTE))]).message
            if kind == "remove":
                pool = [o for o in live if o.class_name in ("car",) + PEOPLE]
                if not pool:
                    return None
                return editor.delete(pool[rng.integers(len(pool))].name).message
            if kind == "add_person":
                p = _surface_point(rng, ground.triangles.get("sidewalk"))
                if p is None:
                    return None
                return editor.add("person", (round(float(p[0]), 3), round(float(p[1]), 3))).message
            if kind == "add_car":
                p = _surface_point(rng, ground.triangles.get("road"))
                if p is None:
                    return None
                cars = [o for o in live if o.class_name in ("car", "truck", "bus")]
                near = min(cars, key=lambda o: (math.dist(o.position_world[:2], p), o.name)) if cars else None
                yaw = math.radians(near.yaw_deg) if near else 0.0
                side = np.array([-math.sin(yaw), math.cos(yaw)]) * PARKED_KERB_M
                kerb, _ = surface_at(np.array([p + side, p - side]), ground)
                if kerb[0] != "road" or kerb[1] != "road":  # parked: the kerb is within reach on one side
                    return editor.add("car", (round(float(p[0]), 3), round(float(p[1]), 3))).message
                continue
            if kind == "move_in_lane":
                pool = [o for o in live if o.class_name in ("car", "truck", "bus")]
                if not pool:
                    return None
                o = pool[rng.integers(len(pool))]
                d = float(rng.uniform(-LANE_MOVE_M, LANE_MOVE_M))
                yaw = math.radians(o.yaw_deg)
                return editor.move(
                    o.name, by=(round(d * math.cos(yaw), 3), round(d * math.sin(yaw), 3))
                ).message
        except EditRefused as exc:
            if exc.reason is not RefusalReason.NOT_PERMISSIBLE:
                raise
            continue
    return None


def _random_edits(editor: WorldEditor, rng: np.random.Generator) -> list[str]:
    """Make 3-8 random permissible edits; a kind with no permissible candidate gives way to another."""
    applied = []
    for _ in range(int(rng.integers(EDITS_PER_VARIATION[0], EDITS_PER_VARIATION[1] + 1))):
        kinds = list(KINDS)
        while kinds:
            kind = kinds.pop(int(rng.integers(len(kinds))))
            try:
                message = _attempt(editor, kind, rng)
            except UsdWorldError:
                message = None
            if message:
                applied.append(message)
                break
    return applied


def make_variations(
    world: Path | str,
    n: int,
    seed: int,
    out_dir: Path | str,
    *,
    surface_rules: Path | str | None = None,
    replacement_rules: Path | str | None = None,
    library: Path | str | None = None,
) -> list[Variation]:
    """Write ``n`` variations of a world into ``out_dir``.

    Args:
        world: the world's root layer or folder.
        n: number of variations (>= 1).
        seed: random seed; the same seed gives the same files.
        out_dir: folder to write ``variation_NNNN.usda`` and ``variation_NNNN.edits.usda`` into
            (created; existing variations of the same numbers are replaced).
        surface_rules: surface rule table (default as for editing).
        replacement_rules: replacement rule table.
        library: user asset library.

    Returns:
        The variations written, in order.

    Raises:
        InputError: bad ``n`` or world.
    """
    if n < 1:
        raise InputError(f"-n: must be >= 1, got {n}")
    root = world_root(world)
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(
            f"{out}: cannot create the output folder ({exc.strerror}); choose another -o"
        ) from exc
    layer = Sdf.Layer.FindOrOpen(str(root))
    if layer is None:
        raise InputError(f"{root}: not a readable USD layer")
    world_layers = [Path(layer.ComputeAbsolutePath(p)) for p in layer.subLayerPaths]
    shared = [Path(os.path.relpath(p, out.resolve())).as_posix() for p in world_layers]
    done = []
    for i in range(1, n + 1):
        name = f"variation_{i:04d}"
        edits, var_root = out / f"{name}.edits.usda", out / f"{name}.usda"
        atomic_write_text(edits, "#usda 1.0\n\n")
        _write_root(var_root, [edits.name, *shared])
        rng = np.random.default_rng([seed, i])
        with WorldEditor(
            var_root,
            surface_rules=surface_rules,
            replacement_rules=replacement_rules,
            library=library,
            clock=lambda: "",
        ) as editor:
            applied = _random_edits(editor, rng)
        lock = edits.with_name(edits.name + ".lock")
        lock.unlink(missing_ok=True)
        done.append(Variation(var_root, edits, tuple(applied)))
    return done
