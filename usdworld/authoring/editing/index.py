"""Where a world's objects stand, read from the opinions in its layers without composing them.

One edit needs the object it edits and the objects its footprint could touch; composing
every object of a large world (a reference and a variant each) to find those costs far
more than the edit. :func:`read_index` reads each object's own opinions (translate, scale,
class label, ``model`` variant, active, specifier) from the layer stack, strongest layer
first, as composition would resolve them for opinions on the object prim itself; the
editor then composes only the objects :meth:`ObjectIndex.near` returns.

The opinions are read per group of layers (:class:`Opinions`) and merged: the edits layer's
over those below it, which no edit changes; a large world keeps the latter in a file
(:mod:`.index_file`), so a command reads only its edits layer in Python.

Worlds whose objects carry those opinions elsewhere (a label only in the asset, a
transform that is not translate / rotateZ / scale) give no index, and the editor composes
every object as before.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from itertools import repeat
from pathlib import Path
from typing import Any

import numpy as np
from pxr import Sdf

from usdworld.authoring import asset_library
from usdworld.authoring.asset_library import VARIANT_SET
from usdworld.errors import InputError
from usdworld.world_files import OBJECTS_PATH

_LABEL = "semantics:labels:class"
#: The transform ops of an object the build places, in their order (``xformOpOrder``).
XFORM_OPS = ("xformOp:translate", "xformOp:rotateZ", "xformOp:scale")
#: Metadata a plain object's spec may carry (not a payload, instancing, a kind ...).
_PLAIN_INFO = frozenset(
    {"specifier", "typeName", "references", "variantSelection", "variantSetNames", "apiSchemas"}
)
#: Property names a plain object's spec may carry: its transform ops, its label, its provenance.
_PLAIN_PROPERTIES = (*XFORM_OPS, "xformOpOrder", "semantics:", "usdworld:")


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


@dataclass(frozen=True)
class Opinions:
    """Each object's own opinions in a group of layers, the strongest of the group per field.

    Attributes:
        names: object names: the strongest layer's children first, in layer order.
        defined: (N,) bool, a ``def`` spec in some layer of the group.
        translate: (N, 2) float64 x, y of ``xformOp:translate``, NaN where the group has none.
        scale: (N, 2) float64 x, y of ``xformOp:scale``, NaN where the group has none.
        label: the first ``class`` label, ``""`` for an empty label list, None for none.
        variant: the ``model`` variant selection, or None.
        active: the ``active`` opinion, or None.
        z_scale_yaw: (N, 3) float64 z of ``xformOp:translate``, z of ``xformOp:scale`` and the
            ``xformOp:rotateZ`` angle (degrees), NaN where the group has none (None when made: all NaN).
        asset: the asset path of a plain object's one reference, as authored (relative to its
            layer), else None (None when made: all None).
        plain: (N,) bool, the object is one ``def Xform`` spec in one layer of the group that
            holds nothing but what these fields describe (:func:`plain_asset`): no child, no
            other transform op, metadata or property (a visibility, primvars, a payload ...),
            one reference to an asset's default prim, and no selection but ``model`` (None when
            made: all False). A reader may then compose it from these fields alone (the
            render's view stage).
    """

    names: tuple[str, ...]
    defined: np.ndarray
    translate: np.ndarray
    scale: np.ndarray
    label: tuple[str | None, ...]
    variant: tuple[str | None, ...]
    active: tuple[bool | None, ...]
    z_scale_yaw: np.ndarray | None = field(default=None)
    asset: tuple[str | None, ...] | None = field(default=None)
    plain: np.ndarray | None = field(default=None)

    def __post_init__(self) -> None:
        n = len(self.names)
        if self.z_scale_yaw is None:
            object.__setattr__(self, "z_scale_yaw", np.full((n, 3), np.nan))
        if self.asset is None:
            object.__setattr__(self, "asset", (None,) * n)
        if self.plain is None:
            object.__setattr__(self, "plain", np.zeros(n, dtype=bool))

    def __len__(self) -> int:
        return len(self.names)


def plain_asset(spec: Sdf.PrimSpec) -> str | None:
    """The asset path of an object's spec that holds only what :class:`Opinions` describes, or None.

    Plain: a ``def Xform`` with no child; metadata among specifier, type, references, variant
    selections (``model`` only) and variant set names, API schemas; one prepended reference
    (an asset path, its default prim, no layer offset) and no other reference list item; the
    transform ops translate, rotateZ, scale in that order, each with a value where the index
    reads one; other properties only labels and provenance (``semantics:``, ``usdworld:``).

    Args:
        spec: the object's prim spec.
    """
    if spec.specifier != Sdf.SpecifierDef or spec.typeName != "Xform" or spec.nameChildren:
        return None
    if not _PLAIN_INFO.issuperset(spec.ListInfoKeys()):
        return None
    if not set(spec.variantSelections.keys()) <= {VARIANT_SET}:
        return None
    attrs = spec.attributes
    if not all(map(str.startswith, spec.properties.keys(), repeat(_PLAIN_PROPERTIES))):
        return None
    order = attrs.get("xformOpOrder")
    if order is None or tuple(order.default or ()) != XFORM_OPS:
        return None
    for name in XFORM_OPS:
        if name not in attrs or attrs[name].default is None or attrs[name].HasInfo("timeSamples"):
            return None
    refs = spec.referenceList
    items = refs.prependedItems
    if refs.isExplicit or refs.explicitItems or refs.appendedItems or refs.addedItems or len(items) != 1:
        return None
    ref = items[0]
    if not ref.assetPath or ref.primPath or ref.layerOffset != Sdf.LayerOffset() or ref.customData:
        return None
    return ref.assetPath


def read_opinions(layers: Sequence[Sdf.Layer]) -> Opinions:
    """The opinions on the objects under ``/World/Objects`` in a group of layers.

    Args:
        layers: the layers, strongest first.
    """
    children: dict[str, list[Sdf.PrimSpec]] = {}
    for layer in layers:
        scope = layer.GetPrimAtPath(OBJECTS_PATH)
        if scope:
            for name, spec in scope.nameChildren.items():
                children.setdefault(name, []).append(spec)
    n = len(children)
    defined = np.zeros(n, dtype=bool)
    translate = np.full((n, 2), np.nan)
    scale = np.full((n, 2), np.nan)
    z_scale_yaw = np.full((n, 3), np.nan)
    plain = np.zeros(n, dtype=bool)
    labels: list[str | None] = []
    variants: list[str | None] = []
    actives: list[bool | None] = []
    assets: list[str | None] = []
    for i, specs in enumerate(children.values()):
        defined[i] = any(s.specifier == Sdf.SpecifierDef for s in specs)
        attrs = [s.attributes for s in specs]
        t, s3, label = (_strongest(attrs, k) for k in ("xformOp:translate", "xformOp:scale", _LABEL))
        yaw = _strongest(attrs, "xformOp:rotateZ")
        if yaw is not None:
            z_scale_yaw[i, 2] = float(yaw)
        if t is not None:
            translate[i] = float(t[0]), float(t[1])
            z_scale_yaw[i, 0] = float(t[2])
        if s3 is not None:
            scale[i] = float(s3[0]), float(s3[1])
            z_scale_yaw[i, 1] = float(s3[2])
        asset = plain_asset(specs[0]) if len(specs) == 1 else None
        plain[i] = asset is not None
        assets.append(asset)
        labels.append(None if label is None else (str(label[0]) if len(label) else ""))
        selections = (s.variantSelections.get(VARIANT_SET) for s in specs)
        variants.append(next((v for v in selections if v is not None), None))
        actives.append(next((bool(s.active) for s in specs if s.HasInfo("active")), None))
    return Opinions(
        tuple(children),
        defined,
        translate,
        scale,
        tuple(labels),
        tuple(variants),
        tuple(actives),
        z_scale_yaw,
        tuple(assets),
        plain,
    )


def merge_opinions(upper: Opinions, lower: Opinions) -> Opinions:
    """The opinions of two groups of layers, ``upper`` stronger: field by field, the upper
    group's where it has one. Names: the upper group's first, then the lower's others."""
    if not len(upper):
        return lower
    at = {name: i for i, name in enumerate(lower.names)}
    ups = set(upper.names)
    names = (*upper.names, *(name for name in lower.names if name not in ups))
    src = np.array([at.get(name, -1) for name in names], dtype=np.int64)
    has = src >= 0
    defined = np.zeros(len(names), dtype=bool)
    defined[has] = lower.defined[src[has]]
    translate = np.full((len(names), 2), np.nan)
    translate[has] = lower.translate[src[has]]
    scale = np.full((len(names), 2), np.nan)
    scale[has] = lower.scale[src[has]]
    z_scale_yaw = np.full((len(names), 3), np.nan)
    z_scale_yaw[has] = lower.z_scale_yaw[src[has]]
    plain = np.zeros(len(names), dtype=bool)
    plain[has] = lower.plain[src[has]]
    label = [lower.label[i] if i >= 0 else None for i in src]
    variant = [lower.variant[i] if i >= 0 else None for i in src]
    active = [lower.active[i] if i >= 0 else None for i in src]
    asset = [lower.asset[i] if i >= 0 else None for i in src]
    for j in range(len(upper)):  # the upper group's names are the first rows
        defined[j] |= upper.defined[j]
        if not np.isnan(upper.translate[j, 0]):
            translate[j] = upper.translate[j]
        if not np.isnan(upper.scale[j, 0]):
            scale[j] = upper.scale[j]
        for axis in range(3):
            if not np.isnan(upper.z_scale_yaw[j, axis]):
                z_scale_yaw[j, axis] = upper.z_scale_yaw[j, axis]
        for merged, own in ((label, upper.label), (variant, upper.variant), (active, upper.active)):
            if own[j] is not None:
                merged[j] = own[j]
        # one spec in all the layers: an object of the upper group alone
        plain[j] = upper.plain[j] and src[j] < 0
        asset[j] = upper.asset[j] if plain[j] else None
    return Opinions(
        names,
        defined,
        translate,
        scale,
        tuple(label),
        tuple(variant),
        tuple(active),
        z_scale_yaw,
        tuple(asset),
        plain,
    )


def index_from_opinions(
    opinions: Opinions,
    added: set[str],
    size: Callable[[str, str], tuple[float, float]],
    footprint_size: Callable[[str, str], tuple[float, float]],
    libraries: tuple[Path, ...],
) -> ObjectIndex | None:
    """The index of the objects the opinions define.

    Args:
        opinions: every layer's opinions, merged (:func:`merge_opinions`).
        added: names of the objects the edits layer defines (the others the build placed).
        size: unscaled (length, width) of a class's variant, metres.
        footprint_size: unscaled footprint the rules use for a class's variant, metres.
        libraries: asset folders (for the variant an object gets when none is selected).

    Returns:
        The index, or None when a defined object has no translate, scale or class label.
    """
    keep = np.flatnonzero(opinions.defined)  # only overs: no object in this world (an orphan edit)
    names = [opinions.names[i] for i in keep]
    centers = opinions.translate[keep]
    scale = opinions.scale[keep]
    labels = [opinions.label[i] for i in keep]
    if np.isnan(centers).any() or np.isnan(scale).any() or not all(labels):
        return None
    # one size lookup per (class, variant), not per object
    kinds: dict[tuple[str, str | None], int] = {}
    codes = np.array(
        [kinds.setdefault((c, opinions.variant[i]), len(kinds)) for i, c in zip(keep, labels)], dtype=np.int64
    )
    table = np.empty((len(kinds), 4))
    for (class_name, variant), code in kinds.items():
        if variant is None:
            try:
                variant = asset_library.asset_info(class_name, libraries).default_variant
            except InputError:
                return None  # no asset: the state reader's own fallback applies
        table[code, :2] = size(class_name, variant)
        table[code, 2:] = footprint_size(class_name, variant)
    sizes = table[codes].reshape(-1, 4)
    active = np.array([opinions.active[i] is not False for i in keep], dtype=bool)
    sx, sy = scale[:, 0], scale[:, 1]
    length, width = np.maximum(sizes[:, 0], sizes[:, 2]), np.maximum(sizes[:, 1], sizes[:, 3])
    reach = 0.5 * np.hypot(length * sx, width * sy)
    reach[~active] = 0.0
    built = [name not in added for name in names] if added else [True] * len(names)
    placed_rows = active & np.array(built, dtype=bool)
    placed = None
    if placed_rows.any():
        foot = sizes[placed_rows, 2:] * scale[placed_rows]
        half = 0.5 * np.maximum(foot[:, 0], foot[:, 1])
        xy = centers[placed_rows]
        placed = np.array([(xy - half[:, None]).min(axis=0), (xy + half[:, None]).max(axis=0)])
    return ObjectIndex(tuple(names), centers.reshape(-1, 2), reach, placed)


def added_objects(edits: Sdf.Layer) -> set[str]:
    """Names of the objects an edits layer defines (``def``: added by an edit)."""
    scope = edits.GetPrimAtPath(OBJECTS_PATH)
    if not scope:
        return set()
    return {n for n, spec in scope.nameChildren.items() if spec.specifier == Sdf.SpecifierDef}


def read_index(
    layers: Sequence[Sdf.Layer],
    size: Callable[[str, str], tuple[float, float]],
    footprint_size: Callable[[str, str], tuple[float, float]],
    libraries: tuple[Path, ...],
    lower: Opinions | None = None,
) -> ObjectIndex | None:
    """The index of the objects under ``/World/Objects`` in a layer stack.

    Args:
        layers: the world's sublayers, strongest first (the edits layer first).
        size: unscaled (length, width) of a class's variant, metres.
        footprint_size: unscaled footprint the rules use for a class's variant, metres.
        libraries: asset folders (for the variant an object gets when none is selected).
        lower: the opinions of ``layers[1:]`` when known (:mod:`.index_file`); read from
            the layers when None.

    Returns:
        The index, or None when an object's translate, scale or class label is not
        authored on the object in these layers.
    """
    if lower is None:
        lower = read_opinions(layers[1:])
    merged = merge_opinions(read_opinions(layers[:1]), lower)
    return index_from_opinions(merged, added_objects(layers[0]), size, footprint_size, libraries)
