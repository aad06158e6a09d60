"""The appearance stage of ``build``: each object's and ground surface's colour from the photo.

Wires :mod:`usdworld.perception.appearance` (the colours measured in the photo) to
:func:`usdworld.render.lighting.albedo_for_photo` (the albedo that reproduces them in the
render from the source camera, under the renderer's default lighting, on a lit surface
facing the camera: vertical for objects, the ground for surfaces).

Regions: an object's instance mask, else its box minus nearer objects' boxes; a surface's
label pixels (``road``: road and parking, ``sidewalk``, ``terrain``) when labels are given;
without labels, the terrain stands for the whole visible ground and its region is the
image below the horizon outside every object's box.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from usdworld.geometry.camera import PinholeCamera
from usdworld.io.label_table import label_mask
from usdworld.io.types import Segmentation, SourceImage
from usdworld.layout.model import Appearance
from usdworld.layout.placement import Placement
from usdworld.layout.surfaces import SurfaceMesh
from usdworld.parameters.perception import PerceptionParams
from usdworld.perception.appearance import MeasuredColour, object_colours, region_colour
from usdworld.render.lighting import Lighting, albedo_for_photo

#: Normal of the ground surfaces.
UP_WORLD = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class PhotoColours:
    """The colours measured in the photo, before any lighting: what the albedos are chosen from.

    Attributes:
        objects: (placement index, colour) of each placed object that has one, in placement order.
        surfaces: (surface name, colour) of each ground surface that has one, in the surfaces' order.
    """

    objects: tuple[tuple[int, MeasuredColour], ...]
    surfaces: tuple[tuple[str, MeasuredColour], ...]


def photo_colours(
    image: SourceImage,
    seg: Segmentation | None,
    placements: Sequence[Placement],
    surfaces: Sequence[SurfaceMesh],
    surface_label_ids: dict[str, list[int]],
    camera: PinholeCamera,
    params: PerceptionParams,
    labels_inferred: bool = False,
) -> PhotoColours:
    """The measured colour of every placed object and ground surface that has one.

    Needs no light, so a build measures them while it estimates the light
    (:mod:`usdworld.stage_threads`); :func:`appearances_for` then chooses their albedos.

    Args:
        image: the photo.
        seg: its labels, or None.
        placements: the placed objects.
        surfaces: the ground surfaces.
        surface_label_ids: surface name -> Cityscapes label ids of its pixels.
        camera: the source camera.
        params: ``colour_*`` fields.
        labels_inferred: ``seg`` was inferred from the photo (:mod:`usdworld.perception.streets`),
            not given: the surfaces' colour regions are recorded as ``inferred``.
    """
    boxes = np.array([p.obj.box_px for p in placements], dtype=np.int64).reshape(-1, 4)
    masks = [None if p.obj.box_only else p.obj.mask for p in placements]
    depths = np.array([p.depth_m for p in placements], dtype=np.float64)
    rows = [params.colour_rows(p.obj.class_name) for p in placements]
    objects = tuple(sorted(object_colours(image.rgb, boxes, masks, depths, params, rows).items()))
    measured = []
    for surface in surfaces:
        region = _surface_region(surface.name, seg, surface_label_ids, boxes, camera, image.rgb.shape[:2])
        kind = ("inferred" if labels_inferred else "labels") if seg is not None else "ground"
        colour = region_colour(image.rgb, region, kind, params) if region is not None else None
        if colour is not None:
            measured.append((surface.name, colour))
    return PhotoColours(objects, tuple(measured))


def appearances_for(
    colours: PhotoColours,
    placements: Sequence[Placement],
    camera: PinholeCamera,
    lighting: Lighting | None = None,
) -> tuple[Appearance, ...]:
    """The albedo of each measured colour that reproduces it under ``lighting``.

    Args:
        colours: the colours measured in the photo (:func:`photo_colours` of ``placements``).
        placements: the placed objects.
        camera: the source camera.
        lighting: the lighting the albedo is chosen for (default: the renderer's).

    Returns:
        Objects first (in placement order), then surfaces.
    """
    light = Lighting() if lighting is None else lighting
    out = []
    for i, colour in colours.objects:
        towards_camera = camera.center_world - placements[i].position_world
        towards_camera[2] = 0.0
        if np.linalg.norm(towards_camera) < 1e-6:
            towards_camera = -camera.rotation_world_from_cam[:, 2]
        out.append(_appearance(placements[i].name, "object", colour, towards_camera, light))
    for name, colour in colours.surfaces:
        out.append(_appearance(name, "surface", colour, UP_WORLD, light))
    return tuple(out)


def _appearance(
    target: str, kind: str, colour: MeasuredColour, normal_world: np.ndarray, light: Lighting
) -> Appearance:
    return Appearance(target, kind, colour, albedo_for_photo(colour.linear_rgb, normal_world, light))


def _surface_region(
    name: str,
    seg: Segmentation | None,
    label_ids: dict[str, list[int]],
    boxes_px: np.ndarray,
    camera: PinholeCamera,
    shape: tuple[int, int],
) -> np.ndarray | None:
    """(H, W) bool pixels of a ground surface, or None when nothing marks them."""
    if seg is not None:
        ids = label_ids.get(name)
        return label_mask(seg.label_ids, ids) if ids else None
    if name != "terrain":
        return None
    h, w = shape
    top = int(np.clip(np.ceil(camera.horizon_v()), 0, h))
    region = np.zeros((h, w), dtype=bool)
    region[top:] = True
    for x0, y0, x1, y1 in boxes_px:
        region[max(y0, 0) : max(y1, 0), max(x0, 0) : max(x1, 0)] = False
    return region
