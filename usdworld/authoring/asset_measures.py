"""What placement needs to know about each asset variant's shape, measured once per file.

* contact half extents: where the variant touches the ground (a car's tyre bottoms, a
  person's soles): the lowest image point of an object is its nearest contact;
* contact offset: the centre of that contact's footprint (the middle of its extent along
  each axis) in the asset's frame: a street lamp's mast stands ~0.9 m behind its origin,
  which is the centre of the whole footprint, arm included;
* mean contact reach: that distance averaged over every heading, for objects whose
  heading is unknown (people);
* top half extents: its top (a roof, a head), whose near or far edge is the silhouette's
  top row (:mod:`usdworld.layout.silhouette`);
* top shape: :func:`usdworld.perception.shape.top_shape_ratio` of its side view (a
  conifer's against a broad tree's).

Measures come from the asset's card when it has a current one
(:mod:`usdworld.authoring.asset_cards`; :func:`asset_card_text` makes it), else they are
measured, cached by asset file and modification time, so a batch of builds pays for them
once per process. Frames: the asset's (metres, Z up, origin at the footprint centre).

:func:`asset_catalogue` gathers sizes, variants and measures of the classes a build uses
into the plain :class:`~usdworld.io.asset_catalogue.AssetCatalogue` that layout receives
(reading USD needs pxr, which only authoring and render import).
"""

from __future__ import annotations

import functools
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from usdworld.authoring import asset_library
from usdworld.authoring.asset_cards import asset_digest, card_text
from usdworld.io.asset_catalogue import AssetCatalogue, AssetSizes
from usdworld.perception.shape import top_shape_ratio

#: Vertices this close to an asset's lowest point count as its ground contact (metres):
#: the bottom facets of a car's tyres (a wider band reaches up the tyres' curve and puts
#: the contact ~0.1 m too far out), a person's soles.
CONTACT_HEIGHT_M = 0.01
#: Vertices within this fraction of the height below an asset's top count as its top.
TOP_BAND_FRACTION = 0.05
#: Rows of the side view an asset's top shape is measured on.
SIDE_VIEW_ROWS = 256


@dataclass(frozen=True)
class VariantMeasures:
    """Shape measures of one asset variant at unit scale.

    Attributes:
        contact_half: (half length, half width) of its ground contact about the origin
            (the largest absolute coordinate of a contact point on each axis), metres.
        contact_mean_reach: mean over headings of how far its nearest contact lies from
            the origin, metres.
        top_half: (half length, half width) of its top, metres.
        top_shape: its side view's top-shape ratio.
        contact_offset: (x, y) centre of its ground contact's extent, metres: where a
            trunk's or post's base stands relative to the origin.
    """

    contact_half: tuple[float, float]
    contact_mean_reach: float
    top_half: tuple[float, float]
    top_shape: float
    contact_offset: tuple[float, float]


def measure_mesh(vertices: np.ndarray, faces: np.ndarray) -> VariantMeasures:
    """The measures of one triangle mesh (module docstring).

    Args:
        vertices: (V, 3) float64 asset-frame vertices, metres.
        faces: (F, 3) int vertex indices.
    """
    verts = np.asarray(vertices, dtype=np.float64)
    z0, z1 = float(verts[:, 2].min()), float(verts[:, 2].max())
    low = verts[verts[:, 2] <= z0 + CONTACT_HEIGHT_M][:, :2]
    top = verts[verts[:, 2] >= z1 - TOP_BAND_FRACTION * (z1 - z0)][:, :2]
    angles = np.linspace(0.0, 2.0 * np.pi, 360, endpoint=False)
    directions = np.column_stack([np.cos(angles), np.sin(angles)])
    middle = 0.5 * (low.min(axis=0) + low.max(axis=0))
    return VariantMeasures(
        contact_half=(float(np.abs(low[:, 0]).max()), float(np.abs(low[:, 1]).max())),
        contact_mean_reach=float(np.mean(np.max(low @ directions.T, axis=0))),
        top_half=(float(np.abs(top[:, 0]).max()), float(np.abs(top[:, 1]).max())),
        top_shape=_side_view_top_shape(verts, np.asarray(faces)),
        contact_offset=(float(middle[0]) + 0.0, float(middle[1]) + 0.0),
    )


def _side_view_top_shape(verts: np.ndarray, faces: np.ndarray) -> float:
    """Top-shape ratio of the X-Z silhouette rasterised :data:`SIDE_VIEW_ROWS` rows tall."""
    import cv2  # 30 ms to import; only when an asset without a current card is measured

    z0, z1 = float(verts[:, 2].min()), float(verts[:, 2].max())
    px_per_m = (SIDE_VIEW_ROWS - 1) / max(z1 - z0, 1e-9)
    x = (verts[:, 0] - verts[:, 0].min()) * px_per_m
    y = (z1 - verts[:, 2]) * px_per_m
    image = np.zeros((SIDE_VIEW_ROWS + 1, int(np.ceil(x.max())) + 2), dtype=np.uint8)
    triangles = np.round(np.stack([x, y], axis=1)[faces] * 4).astype(np.int32)
    cv2.fillPoly(image, list(triangles), 1, shift=2)
    ratio = top_shape_ratio(image.astype(bool))
    return 0.0 if ratio is None else ratio


@functools.lru_cache(maxsize=256)
def _cached(
    class_name: str, variant: str | None, path_str: str, mtime_ns: int, libraries: tuple[Path, ...] | None
) -> VariantMeasures:
    card = asset_library.card_cached(path_str, mtime_ns)
    if card is not None:
        key = variant if variant is not None else card["default_variant"]
        if key in card["measures"]:
            m = card["measures"][key]
            return VariantMeasures(
                contact_half=(float(m["contact_half"][0]), float(m["contact_half"][1])),
                contact_mean_reach=float(m["contact_mean_reach"]),
                top_half=(float(m["top_half"][0]), float(m["top_half"][1])),
                top_shape=float(m["top_shape"]),
                contact_offset=(float(m["contact_offset"][0]), float(m["contact_offset"][1])),
            )
    mesh = asset_library.load_mesh_arrays(class_name, variant, libraries)
    return measure_mesh(mesh.vertices, mesh.faces)


def variant_measures(
    class_name: str, variant: str | None = None, libraries: tuple[Path, ...] | None = None
) -> VariantMeasures:
    """The measures of a class asset's variant (default variant when None), cached per file.

    Raises:
        InputError: no asset for the class, or no such variant.
    """
    path = asset_library.asset_path(class_name, libraries).resolve()
    return _cached(class_name, variant, str(path), path.stat().st_mtime_ns, libraries)


def asset_card_text(usda: Path, validation: dict[str, int] | None = None) -> str:
    """The card (:mod:`usdworld.authoring.asset_cards`) of an asset, measured from its files.

    Args:
        usda: the asset's root layer ``<class>.usda``; its folder is the only library searched.
        validation: validator id -> errors found in these files
            (:func:`usdworld.authoring.validate.validation_record`); None when not validated.

    Raises:
        InputError: the asset is not readable, or a variant has no mesh.
    """
    usda = Path(usda).resolve()
    class_name, libraries = usda.stem, (usda.parent,)
    info = asset_library.measure_info(class_name, usda)
    measures = {}
    for v in info.variants or ("",):
        mesh = asset_library.load_mesh_arrays(class_name, v or None, libraries)
        measures[v] = measure_mesh(mesh.vertices, mesh.faces)
    return card_text(asset_digest(usda), info, measures, validation)


def asset_catalogue(class_names: Iterable[str], libraries: tuple[Path, ...] | None = None) -> AssetCatalogue:
    """The catalogue entries (sizes, default variant, measures of every variant) of some classes.

    Args:
        class_names: the classes a build places (repeats are fine).
        libraries: asset library folders, user first (default: the built-in library).

    Returns:
        The catalogue, keyed by class name in sorted order.

    Raises:
        InputError: a class has no asset, or an asset is not readable.
    """
    sizes = {}
    for name in sorted(set(class_names)):
        info = asset_library.asset_info(name, libraries)
        m = {v: variant_measures(name, v, libraries) for v in info.variants}
        sizes[name] = AssetSizes(
            dict(info.size_by_variant),
            info.default_variant,
            contact_half_by_variant={v: x.contact_half for v, x in m.items()},
            top_half_by_variant={v: x.top_half for v, x in m.items()},
            contact_mean_reach_by_variant={v: x.contact_mean_reach for v, x in m.items()},
            top_shape_by_variant={v: x.top_shape for v, x in m.items()},
            contact_offset_by_variant={v: x.contact_offset for v, x in m.items()},
        )
    return AssetCatalogue(sizes)
