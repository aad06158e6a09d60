"""``build``: one image (plus labels or detections and a camera) to a USD world folder.

This module wires the stages together: it chooses which inputs feed which stage and
holds only the small adapters that turn one stage's output into the next one's input. :func:`build` is a pure function of its request (no
global state, picklable arguments), so batch runners can call it in worker processes.
"""

from __future__ import annotations

import json
import logging
import os
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from usdworld.atomic import ensure_output_dir
from usdworld.authoring import asset_library
from usdworld.authoring.asset_measures import variant_measures
from usdworld.authoring.world import EDITS_LAYER, ROOT_LAYER, write_world
from usdworld.depth_stage import DepthOutcome, estimate_depth
from usdworld.errors import InputError, OutputError
from usdworld.geometry.camera import PinholeCamera, ground_correspondences, intrinsics_from_fov
from usdworld.geometry.estimate import (
    CAMERA_HEIGHT_PRIOR_M,
    DEFAULT_HFOV_DEG,
    CameraEstimate,
    HeightObservations,
    estimate_camera,
)
from usdworld.geometry.homography import HomographyFit, apply_homography, estimate_homography
from usdworld.geometry.vanishing import VanishingPoint, street_vanishing_point
from usdworld.io.camera_files import read_camera
from usdworld.io.correspondences import read_correspondences
from usdworld.io.detections import read_detections_json, read_kitti_labels
from usdworld.io.hashing import read_input
from usdworld.io.images import read_image
from usdworld.io.labels import read_polygons, read_segmentation
from usdworld.io.types import CameraSpec, Segmentation, SourceImage
from usdworld.layout.boxes import box_view_angle
from usdworld.layout.model import WorldModel
from usdworld.layout.placement import CURB_HEIGHT_M, AssetSizes, place_objects
from usdworld.layout.priors import prior_for
from usdworld.layout.surfaces import MAX_RANGE_M, build_surfaces, fill_behind_occluders, occluded_ground_mask
from usdworld.layout.yaw import road_axis
from usdworld.perception.classes import label_lookups
from usdworld.perception.dedupe import merge_duplicates
from usdworld.perception.facades import StreetView
from usdworld.perception.objects import (
    ImageObject,
    objects_from_detections,
    objects_from_segmentation,
    sort_objects,
)

log = logging.getLogger(__name__)

#: Placed stuff classes the ground continues behind (trunks, posts; a crown hides only nearby ground).
THIN_OCCLUDERS = ("pole", "traffic_light", "traffic_sign", "tree")
#: How far behind a car, person or pole the hidden road or sidewalk is filled in (metres).
FILL_REACH_M = 8.0
#: Pixel grid (rows x columns) of the correspondences generated from a known camera.
DLT_GRID = (4, 5)
#: The generated correspondences start this fraction of the image height below the horizon.
DLT_HORIZON_MARGIN = 0.05


@dataclass(frozen=True)
class BuildRequest:
    """Everything ``build`` needs; paths only, so it pickles cheaply.

    Attributes:
        image: the photo (PNG or JPEG).
        output: the world folder to create or replace.
        labels: Cityscapes ``*_gtFine_labelIds.png``.
        instances: Cityscapes ``*_gtFine_instanceIds.png``.
        polygons: Cityscapes ``*_gtFine_polygons.json`` (instead of labels/instances).
        detections: KITTI ``label_2`` text or a detections JSON.
        camera: Cityscapes camera JSON, KITTI calib, or a plain camera JSON.
        ground_plane: KITTI ``planes`` file (road plane) for the camera's height and pitch.
        correspondences: manual pixel <-> ground pairs (JSON or CSV).
        depth_map: dense metric depth (npy, 16-bit PNG metres*256, PFM); implies ``depth="file"``.
        depth: depth backend: ``ground`` (no dense map), ``file``, ``monodepth``,
            ``monodepth2`` or ``hf``.
        depth_weights: weights file or folder of a network backend.
        library: a user asset library layered over the built-in one.
        max_range_m: farthest ground distance meshed.
    """

    image: Path
    output: Path
    labels: Path | None = None
    instances: Path | None = None
    polygons: Path | None = None
    detections: Path | None = None
    camera: Path | None = None
    ground_plane: Path | None = None
    correspondences: Path | None = None
    depth_map: Path | None = None
    depth: str = "ground"
    depth_weights: Path | None = None
    library: Path | None = None
    max_range_m: float = MAX_RANGE_M

    def __post_init__(self) -> None:
        if self.instances is not None and self.labels is None:
            raise InputError("--instances needs --labels (the labelIds PNG of the same frame)")
        if self.polygons is not None and self.labels is not None:
            raise InputError("pass either --polygons or --labels/--instances, not both")
        if self.ground_plane is not None and self.camera is None:
            raise InputError("--ground-plane needs --camera (the KITTI calib file of the same frame)")
        if not self.max_range_m > 0:
            raise InputError(f"--max-range must be > 0 m, got {self.max_range_m}")


@dataclass(frozen=True)
class BuildResult:
    """What ``build`` wrote.

    Attributes:
        world: path of the root layer (``OUT/world.usda``).
        model: the metric world.
        report: the content of ``OUT/report.json``.
        kept_edits: True when an existing edits layer was carried over.
    """

    world: Path
    model: WorldModel
    report: dict[str, Any] = field(repr=False)
    kept_edits: bool = False


# --- stages ---------------------------------------------------------------------------


def _read_segmentation(request: BuildRequest, image: SourceImage) -> Segmentation | None:
    if request.polygons is not None:
        return read_polygons(request.polygons, image)
    if request.labels is not None:
        return read_segmentation(request.labels, request.instances, image)
    return None


def _street_view(
    spec: CameraSpec | None, image: SourceImage, vanishing: VanishingPoint | None
) -> StreetView | None:
    """The photo's perspective (for cutting facades), when its horizon is known: from the
    street's vanishing point, else from a given camera pitch (None otherwise).

    The camera is not estimated yet: a missing focal length is the default field of view's
    and a missing height the typical one (facade pieces scale with it). Facades stand on the
    sidewalk: the height is the camera's above it.
    """
    if spec is not None and spec.K is not None:
        K = spec.K
    else:
        K = intrinsics_from_fov(image.width, image.height, DEFAULT_HFOV_DEG)
    height = spec.height_m if spec is not None and spec.height_m is not None else CAMERA_HEIGHT_PRIOR_M[0]
    if vanishing is not None:
        horizon = vanishing.v
    elif spec is not None and spec.pitch is not None:
        horizon = PinholeCamera(image.width, image.height, K, height, spec.pitch, spec.roll or 0.0).horizon_v()
    else:
        return None
    vanishing_u = float(vanishing.u) if vanishing is not None else None
    return StreetView(float(horizon), float(K[0, 0]), float(K[0, 2]), float(height) - CURB_HEIGHT_M, vanishing_u)


def _objects(
    request: BuildRequest, image: SourceImage, seg: Segmentation | None, view: StreetView | None
) -> list[ImageObject]:
    if request.detections is None:
        return objects_from_segmentation(seg, view) if seg is not None else []
    if request.detections.suffix.lower() == ".json":
        dets = read_detections_json(request.detections, image)
    else:
        dets = read_kitti_labels(request.detections, image)
    things = merge_duplicates(objects_from_detections(dets, image.width, image.height, seg))
    stuff = [o for o in objects_from_segmentation(seg, view) if not o.is_thing] if seg is not None else []
    return sort_objects(things + stuff)


def _height_observations(
    objects: list[ImageObject], sizes: dict[str, AssetSizes], image_width: int
) -> HeightObservations:
    """Objects of rigid class height with bottom and top in view; the top's extent beyond
    the contact takes a box's turn from its aspect, else assumes it is seen end on."""
    rows = []
    for o in objects:
        prior = prior_for(o.class_name)
        if not prior.rigid_height or o.top_truncated or o.bottom_truncated or o.bottom_occluded:
            continue
        s = sizes[o.class_name]
        angle = box_view_angle(o, prior, image_width)
        near, far = s.top_offsets(s.default_variant, angle or 0.0, o.box_only)
        rows.append(
            (o.contact_px[0], o.contact_px[1], float(o.box_px[1]), prior.size_m[2], prior.height_std_m, near, far)
        )
    arr = np.array(rows, dtype=np.float64).reshape(-1, 7)
    return HeightObservations(*(arr[:, k].copy() for k in range(7)))


def _road_top_row(seg: Segmentation | None) -> float | None:
    """Highest image row with a meaningful amount of road (>= 0.5 % of the width)."""
    if seg is None:
        return None
    road = np.asarray(seg.label_ids) == label_lookups().id_of("road")
    counts = road.sum(axis=1)
    rows = np.nonzero(counts >= max(2, 0.005 * road.shape[1]))[0]
    return float(rows[0]) if len(rows) else None


def _camera(
    spec: CameraSpec | None,
    image: SourceImage,
    objects: list[ImageObject],
    seg: Segmentation | None,
    sizes: dict[str, AssetSizes],
    vanishing: VanishingPoint | None,
) -> CameraEstimate:
    if spec is None:
        spec_values: tuple = (None, None, None, None, None)
    else:
        spec_values = (spec.K, spec.height_m, spec.pitch, spec.roll, spec.yaw)
    return estimate_camera(
        image.width,
        image.height,
        *spec_values,
        _height_observations(objects, sizes, image.width),
        _road_top_row(seg),
        vanishing=vanishing,  # the photo's own lines measure the horizon when the pitch is not given
    )


def _vanishing_yaw(vanishing: VanishingPoint | None, camera: PinholeCamera) -> float | None:
    """World yaw of the direction the street's vanishing point lies in, or None."""
    if vanishing is None:
        return None
    ray = camera.rays_world(np.array([[vanishing.u, vanishing.v]]))[0]
    return float(np.arctan2(ray[1], ray[0]))


def _ground_fit(request: BuildRequest, camera: PinholeCamera) -> tuple[HomographyFit, str]:
    if request.correspondences is not None:
        pairs = read_correspondences(request.correspondences)
        return estimate_homography(pairs.points_px, pairs.points_ground), "manual"
    px, ground = ground_correspondences(camera, DLT_GRID, DLT_HORIZON_MARGIN)
    return estimate_homography(px, ground), "camera_model"


def _asset_sizes(objects: list[ImageObject], libraries: tuple[Path, ...]) -> dict[str, AssetSizes]:
    sizes = {}
    for name in sorted({o.class_name for o in objects}):
        info = asset_library.asset_info(name, libraries)
        m = {v: variant_measures(name, v, libraries) for v in info.variants}
        sizes[name] = AssetSizes(
            dict(info.size_by_variant),
            info.default_variant,
            contact_half_by_variant={v: x.contact_half for v, x in m.items()},
            top_half_by_variant={v: x.top_half for v, x in m.items()},
            contact_mean_reach_by_variant={v: x.contact_mean_reach for v, x in m.items()},
            top_shape_by_variant={v: x.top_shape for v, x in m.items()},
        )
    return sizes


def _surface_points(
    seg: Segmentation | None, fit: HomographyFit, camera: PinholeCamera, max_range_m: float, name: str = "road"
) -> np.ndarray | None:
    """Road-plane points of every fourth pixel of a surface class (within range), or None.

    A sidewalk's pixels are mapped onto the road plane too: its kerb face, labelled
    sidewalk, stands on the road, so its kerb line comes out right (0.04 m median on the
    synthetic set), while its raised top lands about 10 % too far (its back edge 0.4 m).
    """
    if seg is None:
        return None
    surface = np.asarray(seg.label_ids) == label_lookups().id_of(name)
    ys, xs = np.nonzero(surface[::4, ::4])
    if len(ys) == 0:
        return None
    px = np.column_stack([xs * 4 + 2.0, ys * 4 + 2.0])
    pts = apply_homography(fit.dst_from_src, px)
    _, depth = camera.ground_points(px)
    keep = np.isfinite(pts).all(axis=1) & (depth > 0) & (depth <= max_range_m)
    return pts[keep]


def _ground_occluders(placements: list) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Box, mask and front depth of every placed object the ground continues behind."""
    out = []
    for p in placements:
        o = p.obj
        if o.is_thing or o.class_name in THIN_OCCLUDERS:
            front = float(p.depth_m) - float(np.hypot(*p.size_m[:2])) / 2.0
            out.append((o.box_px, o.mask, max(front, 0.5)))
    return out


def depth_for_image(request: BuildRequest) -> tuple[DepthOutcome, PinholeCamera]:
    """Only the depth stage of a build: the metric depth and the camera it used."""
    image = read_image(request.image)
    seg = _read_segmentation(request, image)
    spec = read_camera(request.camera, image, request.ground_plane) if request.camera is not None else None
    vanishing = street_vanishing_point(image.rgb)
    objects = _objects(request, image, seg, _street_view(spec, image, vanishing))
    sizes = _asset_sizes(objects, asset_library.library_dirs(request.library))
    camera = _camera(spec, image, objects, seg, sizes, vanishing)
    outcome = estimate_depth(request.depth, request.depth_weights, request.depth_map, image, camera.camera, seg, objects)
    return outcome, camera.camera


def build_model(request: BuildRequest, libraries: tuple[Path, ...]) -> WorldModel:
    """Read the inputs and compute the metric world (no output written).

    Args:
        request: the inputs.
        libraries: asset libraries, user first.

    Returns:
        The world model.
    """
    image = read_image(request.image)
    seg = _read_segmentation(request, image)
    spec = read_camera(request.camera, image, request.ground_plane) if request.camera is not None else None
    vanishing = street_vanishing_point(image.rgb)
    objects = _objects(request, image, seg, _street_view(spec, image, vanishing))
    sizes = _asset_sizes(objects, libraries)
    camera = _camera(spec, image, objects, seg, sizes, vanishing)
    dense = estimate_depth(
        request.depth, request.depth_weights, request.depth_map, image, camera.camera, seg, objects
    )
    depth = dense.depth_map
    fit, dlt_source = _ground_fit(request, camera.camera)
    axis = road_axis(
        _surface_points(seg, fit, camera.camera, request.max_range_m),
        vanishing_angle=_vanishing_yaw(vanishing, camera.camera),
    )
    placements, skipped = place_objects(
        objects,
        camera.camera,
        fit.dst_from_src,
        axis,
        sizes,
        depth,
        camera_sigma=(camera.sigma_height_m, camera.sigma_pitch),
        max_partial_depth_m=request.max_range_m,
        sidewalk_ground=_surface_points(seg, fit, camera.camera, request.max_range_m, "sidewalk"),
    )
    lk = label_lookups()
    surface_ids = {"road": [lk.id_of("road"), lk.id_of("parking")], "sidewalk": [lk.id_of("sidewalk")]}
    filled = None
    if seg is not None:
        labels = np.asarray(seg.label_ids)
        fill = occluded_ground_mask(labels.shape, _ground_occluders(placements), camera.camera, FILL_REACH_M)
        ahead = np.array([np.cos(axis.angle), np.sin(axis.angle), 0.0])
        road_vp = camera.camera.vanishing_point(ahead) or (camera.camera.cx, camera.camera.horizon_v())
        filled = fill_behind_occluders(labels, fill, road_vp)
    surfaces = tuple(
        build_surfaces(filled, surface_ids, camera.camera, fit.dst_from_src, CURB_HEIGHT_M, request.max_range_m)
    )
    inputs = [image.file]
    if seg is not None:
        inputs.extend(seg.files)
    for path, role in ((request.detections, "detections"), (request.correspondences, "correspondences")):
        if path is not None:
            inputs.append(read_input(path, role)[1])
    if spec is not None:
        inputs.append(spec.file)
        inputs.extend(spec.extra_files)
    if request.depth_map is not None:
        inputs.append(read_input(request.depth_map, "depth_map")[1])
    warnings = []
    if not objects:
        warnings.append(f"{image.file.name}: no objects found; the world has ground and camera only")
    if skipped:
        warnings.append(
            f"not placed (no visible ground contact, or only a bound beyond {request.max_range_m:g} m): "
            + ", ".join(skipped)
        )
    if camera.estimated:
        warnings.append(f"camera estimated ({', '.join(camera.estimated)}): {camera.method}")
    return WorldModel(
        image_name=image.file.name,
        image_size=(image.width, image.height),
        camera=camera,
        ground_fit=fit,
        dlt_source=dlt_source,
        placements=tuple(placements),
        surfaces=surfaces,
        inputs=tuple(inputs),
        depth_source=dense.source,
        depth_kind=dense.kind,
        depth_alignment=dense.alignment,
        depth_fit=dense.fit,
        warnings=tuple(warnings),
    )


# --- report ---------------------------------------------------------------------------


def _num(x: float | None) -> float | None:
    if x is None:
        return None
    x = float(x)
    return round(x, 6) if np.isfinite(x) else None


def make_report(model: WorldModel) -> dict[str, Any]:
    """The ``report.json`` content: the same numbers as the USD provenance."""
    cam = model.camera.camera
    objects = []
    for p in model.placements:
        o = p.obj
        objects.append(
            {
                "name": p.name,
                "class": o.class_name,
                "source_class": o.source_label,
                "instance_id": int(o.instance_id),
                "variant": p.variant,
                "image_bbox": [int(b) for b in o.box_px],
                "contact_px": [_num(c) for c in o.contact_px],
                "mask_area": o.mask_area,
                "bottom_truncated": o.bottom_truncated,
                "bottom_occluded": o.bottom_occluded,
                "standing_on": o.standing_on,
                "position_world": [_num(c) for c in p.position_world],
                "yaw_deg": _num(np.degrees(p.yaw)),
                "yaw_source": p.yaw_source,
                "depth_m": _num(p.depth_m),
                "depth_method": p.depth_method,
                "depth_cues": {
                    c.name: {"depth_m": _num(c.depth_m), "sigma_m": _num(c.sigma_m), "note": c.note} for c in p.cues
                },
                "scale": _num(p.scale),
                "scale_measured": _num(p.scale_measured),
                "size_m": [_num(s) for s in p.size_m],
                "collision_displacement_m": [_num(d) for d in p.collision_displacement],
                "confidence": _num(p.confidence),
            }
        )
    return {
        "usdworld_version": __import__("usdworld").__version__,
        "source_image": model.image_name,
        "image_size": list(model.image_size),
        "camera": {
            "K": [[_num(v) for v in row] for row in cam.K],
            "height_m": _num(cam.height_m),
            "pitch_deg": _num(np.degrees(cam.pitch)),
            "roll_deg": _num(np.degrees(cam.roll)),
            "yaw_deg": _num(np.degrees(cam.yaw)),
            "estimated": list(model.camera.estimated),
            "sigma_height_m": _num(model.camera.sigma_height_m),
            "sigma_pitch_deg": _num(np.degrees(model.camera.sigma_pitch)),
            "method": model.camera.method,
        },
        "dlt": {
            "source": model.dlt_source,
            "ground_from_px": [[_num(v) for v in row] for row in model.ground_fit.dst_from_src],
            "points_px": [[_num(v) for v in row] for row in model.ground_fit.src],
            "points_ground_m": [[_num(v) for v in row] for row in model.ground_fit.dst],
            "rms_px": _num(model.ground_fit.rms_src),
        },
        "depth": {
            "source": model.depth_source,
            "kind": model.depth_kind,
            "alignment": model.depth_alignment,
            "fit_scale_shift_inliers_residual": [_num(v) for v in model.depth_fit],
        },
        "inputs": [{"role": f.role, "name": f.name, "sha256": f.sha256} for f in model.inputs],
        "surfaces": [{"name": s.name, "area_m2": _num(s.area_m2)} for s in model.surfaces],
        "objects": objects,
        "warnings": list(model.warnings),
    }


# --- output ---------------------------------------------------------------------------


def _prepare_output(out: Path) -> Path | None:
    """Check the output folder; return an existing edits layer to keep, if any."""
    if out.exists():
        if not out.is_dir():
            raise OutputError(f"{out}: exists and is not a folder; choose another -o")
        if (out / ROOT_LAYER).is_file():
            edits = out / EDITS_LAYER
            return edits if edits.is_file() else None
        if any(out.iterdir()):
            raise OutputError(f"{out}: folder exists, is not empty and holds no {ROOT_LAYER}; choose another -o")
    ensure_output_dir(out.parent)
    return None


def _swap_in(tmp: Path, out: Path) -> None:
    """Replace ``out`` by ``tmp`` with renames only; the old folder is removed last."""
    if out.exists():
        old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old-", dir=out.parent))
        old.rmdir()
        os.replace(out, old)
        try:
            os.replace(tmp, out)
        except OSError:
            os.replace(old, out)
            raise
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.replace(tmp, out)


def build(request: BuildRequest) -> BuildResult:
    """Build a world folder from one image.

    The folder is written next to ``request.output`` under a temporary name and swapped
    in at the end, so an existing world stays untouched when anything fails. An
    existing ``layers/edits.usda`` is carried over into the rebuilt world.

    Args:
        request: the inputs and the output folder.

    Returns:
        What was written.

    Raises:
        UsdWorldError: any bad input (InputError, CalibrationError ...) or an unwritable output.
    """
    out = Path(request.output)
    keep_edits = _prepare_output(out)
    libraries = asset_library.library_dirs(request.library)
    model = build_model(request, libraries)
    asset_files = {c: asset_library.asset_path(c, libraries) for c in sorted({p.obj.class_name for p in model.placements})}
    report = make_report(model)
    try:
        tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.tmp-", dir=out.parent))
    except OSError as exc:
        raise OutputError(f"{out.parent}: cannot write there ({exc.strerror}); choose another -o") from exc
    try:
        write_world(model, tmp, asset_files, keep_edits)
        (tmp / "report.json").write_text(json.dumps(report, indent=2, sort_keys=True) + "\n")
        _swap_in(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    for warning in model.warnings:
        log.warning(warning)
    return BuildResult(out / ROOT_LAYER, model, report, keep_edits is not None)
