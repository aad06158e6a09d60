"""Where a world's objects stand, read from the opinions in its layers without composing them.

One edit needs the object it edits and the objects its footprint could touch; composing
every object of a large world (a reference and a variant each) to find those costs far
more than the edit. :func:`read_index` reads each object's own opinions (translate, scale,
class label, ``model`` variant, active, specifier) from the layer stack, strongest layer
first, as composition would resolve them for opinions on the object prim itself; the
editor then composes only the objects :meth:`ObjectIndex.near` returns.

Worlds whose objects carry those opinions elsewhere (a label only in the asset, a
transform that is not translate / rotateZ / scale) give no index, and the editor composes
every object as before.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from pxr import Sdf

from usdworld.authoring import asset_library
from usdworld.authoring.asset_library import VARIANT_SET
from usdworld.errors import InputError
from usdworld.world_files import OBJECTS_PATH

_LABEL = "semantics:labels:class"


@dataclass(frozen=True)
class ObjectIndex:
    """Footprint centres and reaches of a world's objects.

    Attributes:
        names: object names.
        centers: (N, 2) float64 object origins on the ground, metres.
        reach: (N,) float64 radius around the origin that holds the object's scaled
            footprint (half its diagonal), metres; 0 for deleted objects.
        placed_bounds: (2, 2) float64 ``[[xmin, ymin], [xmax, ymax]]`` of the rule footprints'
            half longest sides around the origins of the active objects the build placed
            (what :meth:`~usdworld.authoring.editing.state.WorldState.ground` adds to the
            ground's extent), or None when there is none.
    """

    names: tuple[str, ...]
    centers: np.ndarray
    reach: np.ndarray
    placed_bounds: np.ndarray | None

    def near(self, center: np.ndarray, reach: float) -> list[str]:
        """Names of the active objects whose footprint could touch a disc.

        Args:
            center: (2,) float64 centre of the disc, metres.
            reach: its radius, metres.
        """
        d = np.hypot(*(self.centers - np.asarray(center, dtype=np.float64)).T)
        hit = (self.reach > 0) & (d <= self.reach + reach + 1e-6)
        return [self.names[i] for i in np.flatnonzero(hit)]


def _strongest(attrs: Sequence[Any], name: str) -> Any:
    """The default value of attribute ``name`` in the strongest spec that has one, or None."""
    for a in attrs:
        if name in a:
            value = a[name].default
            if value is not None:
                return value
    return None


def read_index(
    layers: Sequence[Sdf.Layer],
    size: Callable[[str, str], tuple[float, float]],
    footprint_size: Callable[[str, str], tuple[float, float]],
    libraries: tuple[Path, ...],
) -> ObjectIndex | None:
    """The index of the objects under ``/World/Objects`` in a layer stack.

    Args:
        layers: the world's sublayers, strongest first (the edits layer first).
        size: unscaled (length, width) of a class's variant, metres.
        footprint_size: unscaled footprint the rules use for a class's variant, metres.
        libraries: asset folders (for the variant an object gets when none is selected).

    Returns:
        The index, or None when an object's translate, scale or class label is not
        authored on the object in these layers.
    """
    children: dict[str, list[Sdf.PrimSpec]] = {}
    for layer in layers:
        scope = layer.GetPrimAtPath(OBJECTS_PATH)
        if scope:
            for name, spec in scope.nameChildren.items():
                children.setdefault(name, []).append(spec)
    edits_scope = layers[0].GetPrimAtPath(OBJECTS_PATH)
    added = (
        {n for n, spec in edits_scope.nameChildren.items() if spec.specifier == Sdf.SpecifierDef}
        if edits_scope
        else set()
    )
    names, centers, reach, placed_rows = [], [], [], []
    for name, specs in children.items():
        if not any(s.specifier == Sdf.SpecifierDef for s in specs):
            continue  # only overs: no object in this world (an orphan edit)
        attrs = [s.attributes for s in specs]
        t, s3, labels = (_strongest(attrs, k) for k in ("xformOp:translate", "xformOp:scale", _LABEL))
        if t is None or s3 is None or not labels:
            return None
        class_name = str(labels[0])
        variant = next(
            (v for v in (s.variantSelections.get(VARIANT_SET) for s in specs) if v is not None), None
        )
        if variant is None:
            try:
                variant = asset_library.asset_info(class_name, libraries).default_variant
            except InputError:
                return None  # no asset: the state reader's own fallback applies
        active = next((s.active for s in specs if s.HasInfo("active")), True)
        x, y = float(t[0]), float(t[1])
        names.append(name)
        centers.append((x, y))
        if not active:
            reach.append(0.0)
            continue
        sx, sy = float(s3[0]), float(s3[1])
        (length, width), (foot_l, foot_w) = size(class_name, variant), footprint_size(class_name, variant)
        reach.append(0.5 * math.hypot(max(length, foot_l) * sx, max(width, foot_w) * sy))
        if name not in added:  # the objects the build placed
            placed_rows.append((x, y, 0.5 * max(foot_l * sx, foot_w * sy)))
    placed = None
    if placed_rows:
        rows = np.array(placed_rows, dtype=np.float64)
        placed = np.array([(rows[:, :2] - rows[:, 2:]).min(axis=0), (rows[:, :2] + rows[:, 2:]).max(axis=0)])
    return ObjectIndex(
        tuple(names), np.array(centers, dtype=np.float64).reshape(-1, 2), np.array(reach), placed
    )
