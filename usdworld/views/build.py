"""``build --views``: several views of one rig to one world folder (pipeline level: wiring only).

Each view runs the single-image stages (:func:`usdworld.pipeline.perceive`,
:func:`~usdworld.pipeline.place_view`, :func:`~usdworld.pipeline.finish_view`) with its
exact intrinsics and the camera its pose gives (height, pitch, roll above the ground; no
estimation), in a local process pool when there are several. Their placements are moved
into the rig's world (:mod:`usdworld.views.rig`), associated and fused
(:mod:`usdworld.views.fusion`) and stand on one ground (:mod:`usdworld.views.ground`); the
world is written as a single image's is, then the rig's cameras and the multi-view
provenance are added (:mod:`usdworld.authoring.rig`).

The world's scene-level provenance (camera height, homography ...) and ``SourceCamera``
are the first view's, so single-view tools keep working; ``/World/Cameras/<name>`` holds
every view's camera at its pose.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import os
import shutil
import tempfile
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from usdworld.authoring import asset_library
from usdworld.errors import InputError, OutputError
from usdworld.io.camera_files import read_camera
from usdworld.io.images import read_image
from usdworld.io.types import CameraSpec, InputFile
from usdworld.layout.model import Appearance, WorldModel
from usdworld.output_dir import prepare_output, swap_in, temporary_prefix
from usdworld.parameters import DEFAULT_PARAMETERS, Parameters
from usdworld.parameters.base import plain, section_rows
from usdworld.parameters.placement import PlacementParams
from usdworld.parameters.views import ViewsParams
from usdworld.pipeline import (
    BuildRequest,
    BuildResult,
    PerceivedView,
    PlacedView,
    finish_view,
    perceive,
    place_view,
)
from usdworld.report import make_report
from usdworld.views.drive import DriveObject, frame_times, track_drive
from usdworld.views.fusion import ContactRow, FusedObject, fuse, observations
from usdworld.views.ground import rig_surfaces
from usdworld.views.rig import ground_pose, world_from_ground
from usdworld.views.types import ViewSet, ViewSpec
from usdworld.views.unevenness import ground_height_spread, ground_heights

log = logging.getLogger(__name__)

#: What ``build --views`` may name: a views manifest, or an mmdetection3d nuScenes info file.
LAYOUTS = ("manifest", "nuscenes")


def read_view_set(path: Path, layout: str, sample: str | None) -> ViewSet:
    """The views ``build --views PATH --layout LAYOUT [--sample TOKEN]`` names; with ``--layout
    nuscenes`` a folder ``PATH`` is a nuScenes dataroot (``build --dataroot``).

    Raises:
        InputError: an unknown layout, ``--sample`` with a manifest, or a bad file.
    """
    from usdworld.views.manifest import read_views_manifest
    from usdworld.views.nuscenes import read_nuscenes_views

    if layout not in LAYOUTS:
        raise InputError(f"--layout must be one of {', '.join(LAYOUTS)}, got {layout!r}")
    if layout == "manifest":
        if sample is not None:
            raise InputError("--sample picks a sample of a nuScenes info file; use it with --layout nuscenes")
        return read_views_manifest(path)
    if Path(path).is_dir():  # a nuScenes dataroot (build --dataroot), read through nuscenes-devkit
        from usdworld.views.nuscenes_devkit import read_devkit_views

        return read_devkit_views(Path(path), sample)
    return read_nuscenes_views(path, sample)


@dataclass(frozen=True)
class ViewsRequest:
    """Everything :func:`build_views` needs; picklable, so each view can build in a worker process.

    Attributes:
        views: the rig's views (:func:`~usdworld.views.manifest.read_views_manifest`,
            :func:`~usdworld.views.nuscenes.read_nuscenes_views`).
        output: the world folder to create or replace.
        depth: depth backend of every view (as ``build --depth``).
        depth_weights: weights of a network backend.
        library: a user asset library layered over the built-in one.
        max_range_m: farthest ground distance meshed; replaces ``params.scene.max_range_m``.
        params: the single-image stages' tuned numbers.
        views_params: the fusion's tuned numbers.
        traffic: the side traffic keeps to.
        jobs: worker processes for the views; None for one per view up to the CPU count, 1 for none.
    """

    views: ViewSet
    output: Path
    depth: str = "ground"
    depth_weights: Path | None = None
    library: Path | None = None
    max_range_m: float | None = None
    params: Parameters = DEFAULT_PARAMETERS
    views_params: ViewsParams = field(default_factory=ViewsParams)
    traffic: str = "right"
    jobs: int | None = None

    def __post_init__(self) -> None:
        if self.jobs is not None and self.jobs < 1:
            raise InputError(f"--jobs must be >= 1, got {self.jobs}")
        self.view_request(self.views.views[0], self.views.source, None)  # checks the shared options once

    @property
    def parameters(self) -> Parameters:
        """The single-image parameters used: ``params``, with ``max_range_m`` in place when given."""
        if self.max_range_m is None:
            return self.params
        return self.params.replace(scene={"max_range_m": float(self.max_range_m)})

    def view_request(self, view: ViewSpec, source: InputFile, spec: CameraSpec | None) -> BuildRequest:
        """The single-image request of one view (its camera given as ``spec``)."""
        return BuildRequest(
            image=view.image,
            output=self.output,
            labels=view.labels,
            instances=view.instances,
            polygons=view.polygons,
            detections=view.detections,
            depth=self.depth,
            depth_weights=self.depth_weights,
            library=self.library,
            max_range_m=self.max_range_m,
            params=self.params,
            traffic=self.traffic,
            camera_spec=spec,
            detection_items=view.detection_items,
            # Each view would infer its own facades from boxes, and the fusion associates things only:
            # the street inference is for single photos.
            infer_streets=False,
            # The views run side by side in processes (``jobs``): each view's stages one after another.
            threads=1,
        )


@dataclass(frozen=True)
class RigModel:
    """The fused world and what each view contributed.

    Attributes:
        model: the world (placements and ground in the rig's world frame; camera and
            scene provenance of the first view).
        objects: the fused objects with their observations, in the order of ``model.placements``.
        views: the views.
        view_models: each view's own world, in its ground frame.
        world_from_ground: each view's (4, 4) float64 ground frame in the world.
        drive: for a drive (:func:`usdworld.views.drive.frame_times`), each object's track, in
            the order of ``objects``; None for a rig of one moment.
        frame_times: for a drive, each view's frame time, seconds; else None.
        ground_spread_m: the ground's height spread about the plane under the car that the
            views' objects measure (:func:`measured_ground_spread`), metres; 0 when they
            agree with a flat ground within their cues' spreads.
    """

    model: WorldModel
    objects: tuple[FusedObject, ...]
    views: ViewSet
    view_models: tuple[WorldModel, ...] = field(repr=False)
    world_from_ground: tuple[np.ndarray, ...] = field(repr=False)
    drive: tuple[DriveObject, ...] | None = field(default=None, repr=False)
    frame_times: list[float] | None = field(default=None, repr=False)
    ground_spread_m: float = 0.0


def view_camera_spec(view: ViewSpec, source: InputFile) -> CameraSpec:
    """The camera of one view: its intrinsics (``K`` or its camera file's) with the height,
    pitch and roll its pose gives, and yaw 0 (its ground frame's X is its heading).

    Raises:
        InputError: a camera file that gives no intrinsics, or one that does not fit the photo.
    """
    height_m, pitch, roll = ground_pose(view.world_from_cam)
    if view.camera is None:  # ViewSpec holds K or a camera file
        file = InputFile("camera", f"{source.name}#{view.name}", source.sha256)
        return CameraSpec(view.K, height_m, pitch, roll, 0.0, "views", file)
    read = read_camera(view.camera, read_image(view.image))
    if read.K is None:
        raise InputError(
            f"{read.file.name}: gives no intrinsics; view {view.name} needs K or a camera file with them"
        )
    return CameraSpec(read.K, height_m, pitch, roll, 0.0, read.source, read.file, read.extra_files)


def perceive_view(request: ViewsRequest, index: int) -> PerceivedView:
    """One view's work up to the placement (:func:`usdworld.pipeline.perceive`), with its camera."""
    view = request.views.views[index]
    spec = view_camera_spec(view, request.views.source)
    return perceive(
        request.view_request(view, request.views.source, spec), asset_library.library_dirs(request.library)
    )


def view_model(request: ViewsRequest, index: int) -> WorldModel:
    """One view's own world, in its ground frame, placed with the request's parameters."""
    return finish_view(place_view(perceive_view(request, index)))


def _perceived_and_placed(request: ViewsRequest, index: int) -> PlacedView:
    """A worker process's first task: one view perceived and placed with the request's parameters."""
    return place_view(perceive_view(request, index))


def _view_world(placed: PlacedView, placement: PlacementParams | None) -> WorldModel:
    """A worker process's second task: one view's world from its placements, or, given
    ``placement``, from its objects placed again with those numbers."""
    if placement is not None:
        placed = place_view(placed.perceived, placement)
    return finish_view(placed)


#: ``map`` over the views: the built-in one, or a local process pool's.
ViewMap = Callable[..., list]


@contextmanager
def _view_map(n_views: int, jobs: int | None) -> Iterator[ViewMap]:
    """A map that runs each view's task in a local process pool of ``jobs`` workers (None: one
    per view up to the CPU count), or in this process for one worker; one pool serves every pass."""
    workers = min(n_views, jobs or os.cpu_count() or 1)
    if workers <= 1:
        yield lambda fn, *args: list(map(fn, *args))
        return
    with ProcessPoolExecutor(max_workers=workers) as pool:
        yield lambda fn, *args: list(pool.map(fn, *args))


def measured_ground_spread(views: Sequence[PlacedView]) -> float:
    """The rig's ground height spread about the plane under the car, metres, measured from every
    view's placed objects (:mod:`usdworld.views.unevenness`)."""
    return ground_height_spread(
        ground_heights((v.placements, v.perceived.head.camera.camera.height_m) for v in views)
    )


def _uneven_request(request: ViewsRequest, spread_m: float) -> ViewsRequest:
    """``request`` with the measured ground spread added, in quadrature, to the contact cues' unevenness."""
    given = request.params.placement.ground_height_sigma_m
    params = request.params.replace(placement={"ground_height_sigma_m": float(math.hypot(given, spread_m))})
    return dataclasses.replace(request, params=params)


def build_rig_model(request: ViewsRequest) -> RigModel:
    """Build every view, move its objects into the world, fuse them and make one ground (no output written).

    Each view is perceived once (:func:`perceive_view`) and placed with the request's
    parameters; when their objects measure a ground that departs from the plane under the car
    (:func:`measured_ground_spread` > 0), the views are placed again (:func:`usdworld.pipeline.place_view`,
    from what they perceived) with that spread widening their contact cues, so each object's
    depth leans on its class height where its contact is unsure (:attr:`RigModel.ground_spread_m`).
    What follows from the placements (light, colours: :func:`usdworld.pipeline.finish_view`) runs
    once, on the final ones. Both passes run in one local process pool when ``request.jobs``
    allows several workers.
    """
    n = len(request.views.views)
    with _view_map(n, request.jobs) as view_map:
        placed = view_map(_perceived_and_placed, [request] * n, range(n))
        spread = measured_ground_spread(placed)
        placement = None
        if spread > 0.0:
            # Only the placement reads the contact cues' unevenness: each view is placed again from
            # what it perceived (its photo, objects, camera and depth are not measured again).
            request = _uneven_request(request, spread)
            placement = request.parameters.placement
        view_models = view_map(_view_world, placed, [placement] * n)
    views = request.views.views
    poses = [
        world_from_ground(v.world_from_cam, m.camera.camera.world_from_cam())
        for v, m in zip(views, view_models)
    ]
    obs = []
    row_error = request.parameters.perception.contact_row_error_px
    for i, (v, m, pose) in enumerate(zip(views, view_models, poses)):
        cam = m.camera.camera
        row = ContactRow(cam.fy, cam.height_m, row_error)
        obs.extend(
            observations(
                i, v.name, m.image_name, m.placements, pose, request.views_params, row,
                request.parameters.placement.curb_height_m,
            )
        )
    times = frame_times([v.timestamp for v in views], request.views_params)
    drive = None
    if times is not None:  # a drive: frames tracked in time order
        drive = tuple(track_drive(obs, times, request.views_params))
        objects = [d.fused for d in drive]
    else:
        objects = fuse(obs, request.views_params)
    params = request.parameters
    surfaces = rig_surfaces(
        [(m.surfaces, pose) for m, pose in zip(view_models, poses)],
        params.placement.curb_height_m,
        params.scene.max_range_m,
    )
    inputs = [request.views.source]
    for m in view_models:
        inputs.extend(f for f in m.inputs if f not in inputs)
    warnings = [f"{v.name}: {w}" for v, m in zip(views, view_models) for w in m.warnings]
    model = dataclasses.replace(
        view_models[0],
        placements=tuple(o.placement for o in objects),
        surfaces=tuple(surfaces),
        inputs=tuple(inputs),
        warnings=tuple(warnings),
        appearances=rig_appearances(view_models[0].appearances, objects),
    )
    return RigModel(
        model, tuple(objects), request.views, tuple(view_models), tuple(poses), drive, times, spread
    )


def rig_appearances(first: Sequence[Appearance], objects: Sequence[FusedObject]) -> tuple[Appearance, ...]:
    """The first view's measured looks carried over to the rig's objects.

    The first view names its objects by its own count; the rig's objects are renamed when
    views are fused or a drive is tracked (and fewer when one object's pieces are joined). An
    object's look is the one the first view measured for its observation of it there (the
    first such when the first view saw it in pieces); objects the first view did not see get
    none, and the ground surfaces keep theirs.

    Args:
        first: the first view's appearances.
        objects: the rig's objects, their observations naming the views' placements.

    Returns:
        The appearances, object targets named as the rig names them.
    """
    rig_name: dict[str, str] = {}
    for o in objects:
        for ob in o.observations:
            if ob.view == 0:
                rig_name.setdefault(ob.placement.name, o.placement.name)
    out: list[Appearance] = []
    taken: set[str] = set()
    for look in first:
        if look.kind != "object":
            out.append(look)
            continue
        target = rig_name.get(look.target)
        if target is not None and target not in taken:
            taken.add(target)
            out.append(dataclasses.replace(look, target=target))
    return tuple(out)


def rig_report(rig: RigModel, request: ViewsRequest) -> dict[str, Any]:
    """``report.json`` of a rig: the single-image report of the fused world plus ``views``."""
    used = _uneven_request(request, rig.ground_spread_m) if rig.ground_spread_m > 0.0 else request
    report = make_report(rig.model, used.parameters)
    methods = [o.method for o in rig.objects]
    report["views"] = {
        "frame": rig.views.frame,
        "source": rig.views.source.name,
        "cameras": [
            {
                "name": v.name,
                "image": m.image_name,
                "timestamp": v.timestamp,
                "world_from_cam": [[float(x) for x in row] for row in v.world_from_cam],
                "objects_placed": len(m.placements),
            }
            for v, m in zip(rig.views.views, rig.view_models)
        ],
        "objects": {
            o.placement.name: {
                "method": o.method,
                "sigma_m": [float(np.sqrt(max(e, 0.0))) for e in np.linalg.eigvalsh(o.covariance)],
                "observations": [
                    {
                        "view": ob.view_name,
                        "image_bbox": [float(b) for b in ob.placement.obj.box_px],
                        "position_world": [float(c) for c in ob.placement.position_world],
                        "depth_m": float(ob.placement.depth_m),
                        "depth_method": ob.placement.depth_method,
                        "sigma_range_m": ob.sigma_range_m,
                        "sigma_lateral_m": ob.sigma_lateral_m,
                    }
                    for ob in o.observations
                ],
            }
            for o in rig.objects
        },
        "fusion": {m: methods.count(m) for m in ("single", "fused", "triangulated", "tracked")},
        "ground_spread_m": rig.ground_spread_m,
        **({"drive": _drive_report(rig.drive)} if rig.drive is not None else {}),
        "parameters": {row["name"]: plain(row["value"]) for row in section_rows(request.views_params)},
    }
    return report


def _drive_report(drive: tuple[DriveObject, ...]) -> dict[str, Any]:
    """``views -> drive`` of a drive's report: per object whether it moves, its velocity and frames."""
    return {
        "moving": sum(d.moving for d in drive),
        "standing": sum(not d.moving for d in drive),
        "objects": {
            d.fused.placement.name: {
                "moving": bool(d.moving),
                "velocity_mps": [float(v) for v in d.velocity],
                "times": [float(t) for t in d.times],
                "positions_world": [[float(c) for c in p] for p in d.positions],
            }
            for d in drive
        },
    }


def build_views(request: ViewsRequest) -> BuildResult:
    """Build one world folder from the views of a rig (written and swapped in as :func:`usdworld.pipeline.build` does).

    Raises:
        UsdWorldError: any bad input or an unwritable output.
    """
    from usdworld.authoring.rig import write_drive, write_rig  # lazy: pxr
    from usdworld.authoring.world import ROOT_LAYER, write_world

    out = Path(request.output)
    keep_edits = prepare_output(out)
    rig = build_rig_model(request)
    libraries = asset_library.library_dirs(request.library)
    asset_files = asset_library.asset_files((p.obj.class_name for p in rig.model.placements), libraries)
    report = rig_report(rig, request)
    try:
        tmp = Path(tempfile.mkdtemp(prefix=temporary_prefix(out), dir=out.parent))
    except OSError as exc:
        raise OutputError(f"{out.parent}: cannot write there ({exc.strerror}); choose another -o") from exc
    try:
        write_world(rig.model, tmp, asset_files, keep_edits)
        write_rig(
            tmp, rig.views, rig.view_models, rig.world_from_ground, rig.objects, object_provenance=rig.drive is None
        )
        if rig.drive is not None and rig.frame_times is not None:
            write_drive(tmp, rig.view_models, rig.world_from_ground, rig.drive, rig.frame_times)
        (tmp / "report.json").write_text(json.dumps(report, indent=2, sort_keys=True) + "\n")
        swap_in(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    for warning in rig.model.warnings:
        log.warning(warning)
    return BuildResult(out / ROOT_LAYER, rig.model, report, keep_edits is not None)
