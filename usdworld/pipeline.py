"""``build``: one image (plus labels or detections and a camera) to a USD world folder.

This module only wires the stages together: it chooses which inputs feed which stage and
holds only the small adapters that turn one stage's output into the next one's input;
every decision and threshold lives in the stages and in :class:`~usdworld.parameters.Parameters`.
:func:`build` is a pure function of its request (no global state, picklable arguments),
so batch runners can call it in worker processes.

Stages, in order: read the image, labels and camera (io); the street's vanishing point;
image objects (perception); the asset catalogue of their classes; the camera estimate;
dense depth; the ground homography; the road axis; placement; the ground surfaces; the
sun and sky (light, from the shadows the placed objects cast and the sky's pixels); the
colours of objects and surfaces measured in the photo (appearance, for that light); the
world's layers and ``report.json``.

Stages that need nothing from each other run side by side on ``BuildRequest.threads`` threads
(:mod:`usdworld.stage_threads`): the photo's decoding and the street's lines while the label maps are
decoded, the camera read and the label map's regions found; the light while the ground surfaces are
built and the colours measured. Each result is taken where the sequential build used it, so the world is the same for
any thread count.

:func:`build_model` runs them in three typed steps, so a photo can be placed again with other
placement numbers without being perceived again (a camera rig, :mod:`usdworld.views.build`):
:func:`perceive` (everything up to the placement: :class:`PerceivedView`), :func:`place_view`
(the road axis and the placements: :class:`PlacedView`) and :func:`finish_view` (surfaces,
light, colours: the :class:`~usdworld.layout.model.WorldModel`).
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import shutil
import tempfile
from concurrent.futures import Future
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from usdworld.appearance_stage import PhotoColours, appearances_for, photo_colours
from usdworld.authoring import asset_library
from usdworld.authoring.asset_measures import asset_catalogue
from usdworld.authoring.world import ROOT_LAYER, write_world
from usdworld.depth_stage import DepthOutcome, estimate_depth
from usdworld.errors import InputError, OutputError
from usdworld.geometry.camera import PinholeCamera, ground_correspondences
from usdworld.geometry.estimate import CameraEstimate, PosePrior, estimate_camera
from usdworld.geometry.homography import HomographyFit, estimate_homography
from usdworld.geometry.vanishing import (
    VanishingPoint,
    detect_segments,
    find_vanishing_point,
    find_vertical_vanishing_point,
)
from usdworld.io.asset_catalogue import AssetCatalogue
from usdworld.io.camera_files import read_camera
from usdworld.io.class_table import ClassTable, load_class_table
from usdworld.io.hashing import read_input
from usdworld.io.images import read_image
from usdworld.io.label_table import label_lookups
from usdworld.io.labels import decode_segmentation, read_polygons
from usdworld.io.limits import MAX_RANGE_CAP_M
from usdworld.io.types import CameraSpec, Detections, InputFile, Segmentation, SourceImage
from usdworld.layout.camera_cues import height_observations, road_top_row, street_view, vanishing_yaw
from usdworld.layout.heading import check_traffic
from usdworld.layout.model import WorldModel
from usdworld.layout.placement import Placement, Skipped, place_objects, skip_warnings
from usdworld.layout.surfaces import (
    SURFACE_CLASSES,
    SurfaceMesh,
    build_surfaces,
    fill_hidden_ground,
    surface_points,
)
from usdworld.layout.yaw import RoadAxis, road_axis
from usdworld.light_stage import estimate_scene_light, light_rig, world_lighting
from usdworld.output_dir import prepare_output as _prepare_output
from usdworld.output_dir import swap_in as _swap_in
from usdworld.output_dir import temporary_prefix
from usdworld.parameters import DEFAULT_PARAMETERS, Parameters
from usdworld.parameters.camera import CameraParams
from usdworld.parameters.placement import PlacementParams
from usdworld.perception.facades import StreetView
from usdworld.perception.objects import (
    ImageObject,
    SegmentRegions,
    objects_from_detections,
    objects_from_regions,
    segment_regions,
    sort_objects,
)
from usdworld.perception.segment import BACKEND_NAMES as SEGMENT_BACKENDS
from usdworld.report import make_report
from usdworld.stage_threads import DEFAULT_THREADS, StageThreads, earlier_errors_first

if TYPE_CHECKING:
    from usdworld.geometry.focal import FocalEstimate
    from usdworld.geometry.lanes import LaneMarkings
    from usdworld.geometry.roll import RollMeasurement
    from usdworld.perception.streets import StreetLabels

log = logging.getLogger(__name__)

# The stages of optional inputs (detections, ground points, a segmentation model, no camera
# file or one without the roll) are imported where they run: a build from labels and a whole
# camera file loads none of them.


@dataclass(frozen=True)
class BuildRequest:
    """Everything ``build`` needs; paths and plain values only, so it pickles cheaply.

    Attributes:
        image: the photo (PNG or JPEG).
        output: the world folder to create or replace.
        labels: Cityscapes ``*_gtFine_labelIds.png``.
        instances: Cityscapes ``*_gtFine_instanceIds.png``.
        polygons: Cityscapes ``*_gtFine_polygons.json`` (instead of labels/instances).
        detections: KITTI ``label_2`` text or a detections JSON.
        camera: Cityscapes camera JSON, KITTI calib, or a plain camera JSON.
        ground_plane: KITTI ``planes`` file (road plane): the camera's roll, and a prior on its
            height and pitch that the objects refine (:class:`~usdworld.geometry.estimate.PosePrior`).
        correspondences: manual pixel <-> ground pairs (JSON or CSV).
        depth_map: dense metric depth (npy, 16-bit PNG metres*256, PFM); implies ``depth="file"``.
        depth: depth backend: ``ground`` (no dense map), ``file``, ``monodepth``,
            ``monodepth2`` or ``hf``.
        depth_weights: weights file or folder of a network backend.
        segment: segmentation backend: ``none`` (labels from ``labels``/``polygons`` or
            none) or ``hf`` (:mod:`usdworld.perception.segment`); its output stands in for
            ``labels`` and ``instances``.
        segment_model: the model folder of the ``hf`` segmentation backend.
        library: a user asset library layered over the built-in one.
        max_range_m: farthest ground distance meshed (``--max-range``); when given it
            replaces ``params.scene.max_range_m``.
        params: the tuned numbers (``--params FILE``).
        traffic: the side traffic keeps to, ``right`` or ``left`` (``--traffic``): which
            way vehicles face (:mod:`usdworld.layout.heading`).
        camera_spec: the camera already read, used instead of reading ``camera`` (a view of
            a rig: its known pose gives height, pitch and roll; :mod:`usdworld.views`).
        detection_items: detections already read, used instead of reading ``detections``
            (a nuScenes info's 2D boxes of one camera).
        infer_streets: with detections but no labels, infer the road, sidewalks, buildings,
            vegetation and sky from the photo (:mod:`usdworld.perception.streets`; ``--no-infer-streets``
            turns it off).
        threads: threads the build runs its independent stages on, the calling one included
            (:mod:`usdworld.stage_threads`): the photo's decoding and the street's lines beside the
            labels' decoding and regions, the light beside the ground surfaces and the colours. 1 runs them one after the other (batch
            workers and a rig's views do: their processes are the parallelism). The world is the
            same for any count.
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
    segment: str = "none"
    segment_model: Path | None = None
    library: Path | None = None
    max_range_m: float | None = None
    params: Parameters = DEFAULT_PARAMETERS
    traffic: str = "right"
    camera_spec: CameraSpec | None = None
    detection_items: Detections | None = None
    infer_streets: bool = True
    threads: int = DEFAULT_THREADS

    def __post_init__(self) -> None:
        check_traffic(self.traffic)
        if isinstance(self.threads, bool) or not isinstance(self.threads, int) or self.threads < 1:
            raise InputError(f"threads must be an integer >= 1, got {self.threads!r}")
        if self.instances is not None and self.labels is None:
            raise InputError("--instances needs --labels (the labelIds PNG of the same frame)")
        if self.polygons is not None and self.labels is not None:
            raise InputError("pass either --polygons or --labels/--instances, not both")
        if self.segment not in SEGMENT_BACKENDS:
            raise InputError(f"--segment must be one of {', '.join(SEGMENT_BACKENDS)}, got {self.segment!r}")
        if self.segment != "none" and (self.labels is not None or self.polygons is not None):
            raise InputError("pass either --segment (labels from a model) or --labels/--polygons (labels from files), not both")
        if self.segment_model is not None and self.segment == "none":
            raise InputError("--segment-model needs --segment hf (the backend that loads it)")
        if self.ground_plane is not None and self.camera is None:
            raise InputError("--ground-plane needs --camera (the KITTI calib file of the same frame)")
        given = self.max_range_m is not None
        max_range = float(self.max_range_m) if given else self.params.scene.max_range_m  # type: ignore[arg-type]
        if not 0 < max_range <= MAX_RANGE_CAP_M:
            what = "--max-range" if given else "parameters -> scene -> max_range_m"
            raise InputError(
                f"{what} must be > 0 and <= {MAX_RANGE_CAP_M:g} m (the ground is meshed out to it), got {max_range:g}"
            )

    @property
    def parameters(self) -> Parameters:
        """The parameters the build uses: ``params``, with ``max_range_m`` in place when given."""
        if self.max_range_m is None:
            return self.params
        return self.params.replace(scene={"max_range_m": float(self.max_range_m)})


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


@dataclass(frozen=True)
class SceneHead:
    """The stages every use of a photo shares (``build`` and ``usdworld depth``).

    Attributes:
        image: the photo.
        seg: its labels, if given.
        spec: the given camera, if any.
        vanishing: the street's vanishing point, if the photo's lines give one.
        objects: the image objects, sorted.
        catalogue: the asset catalogue of the objects' classes.
        camera: the camera (given, estimated, or both).
        inferred: how the labels were inferred from the photo (then ``seg`` is that map),
            or None when they were given or not inferred.
        inference_warning: why inferring them was given up, or ''.
    """

    image: SourceImage
    seg: Segmentation | None
    spec: CameraSpec | None
    vanishing: VanishingPoint | None
    objects: list[ImageObject]
    catalogue: AssetCatalogue
    camera: CameraEstimate
    inferred: StreetLabels | None = None
    inference_warning: str = ""


# --- adapters -------------------------------------------------------------------------


def _read_detections(request: BuildRequest, image: SourceImage) -> Detections | None:
    if request.detection_items is not None:
        return request.detection_items
    if request.detections is None:
        return None
    from usdworld.io.detections import read_detections_json, read_kitti_labels

    if request.detections.suffix.lower() == ".json":
        return read_detections_json(request.detections, image)
    return read_kitti_labels(request.detections, image)


def _read_segmentation(request: BuildRequest, image: Future[SourceImage]) -> Segmentation | None:
    """The given labels; ``image``: the photo, decoded meanwhile (label maps are decoded before
    it is waited for, and checked against it after; polygons need it to be drawn)."""
    if request.polygons is not None:
        return read_polygons(request.polygons, image.result())
    if request.labels is not None:
        return decode_segmentation(request.labels, request.instances).checked(image.result())
    return None


def require_object_source(request: BuildRequest) -> None:
    """Refuse a single-image build with nothing to find objects in (the photo alone).

    Raises:
        InputError: no labels, polygons, detections or segmentation backend; the message
            names the three ways to give objects.
    """
    sources = (request.labels, request.polygons, request.detections, request.detection_items)
    if all(s is None for s in sources) and request.segment == "none":
        raise InputError(
            f"{Path(request.image).name}: nothing to find objects in; give Cityscapes labels (--labels or "
            "--polygons), 2D detections (--detections) or a segmentation model (--segment hf --segment-model DIR)"
        )


def _label_mask(seg: Segmentation | None, name: str) -> np.ndarray | None:
    """(H, W) bool pixels of the Cityscapes class ``name``; None without labels."""
    if seg is None:
        return None
    return np.asarray(seg.label_ids) == label_lookups().id_of(name)


def _objects(
    dets: Detections | None,
    image: SourceImage,
    seg: Segmentation | None,
    view: StreetView | None,
    table: ClassTable,
    params: Parameters,
    regions: SegmentRegions | None,
) -> list[ImageObject]:
    """The image objects; ``regions``: :func:`segment_regions` of ``seg`` (None without labels)."""
    lookups = label_lookups()
    if dets is None:
        if seg is None or regions is None:
            return []
        return objects_from_regions(regions, seg, view, table, lookups, params.perception)
    from usdworld.perception.dedupe import merge_duplicates
    from usdworld.perception.refs import join_things_and_stuff

    things = merge_duplicates(
        objects_from_detections(dets, image.width, image.height, seg, lookups=lookups, params=params.perception),
        params.collision,
    )
    if seg is None or regions is None:
        return sort_objects(things)
    segmented = objects_from_regions(regions, seg, view, table, lookups, params.perception)
    return join_things_and_stuff(things, segmented, params.perception)


def _camera(
    spec: CameraSpec | None,
    image: SourceImage,
    objects: list[ImageObject],
    seg: Segmentation | None,
    catalogue: AssetCatalogue,
    vanishing: VanishingPoint | None,
    table: ClassTable,
    params: Parameters,
    focal: FocalEstimate | None = None,
    lanes: LaneMarkings | None = None,
    roll: RollMeasurement | None = None,
) -> CameraEstimate:
    pose_prior = None
    if spec is None:
        spec_values: tuple = (None, None, None, None, None)
    else:
        spec_values = (spec.K, spec.height_m, spec.pitch, spec.roll, spec.yaw)
        if spec.height_m is not None and spec.pitch is not None and any(
            f.role == "ground_plane" for f in spec.extra_files
        ):
            # A road plane is fitted round the car; the road under the objects ahead is not that
            # plane: it is a measurement of height and pitch, fused with the objects.
            pose_prior = PosePrior(
                spec.height_m,
                params.camera.plane_height_sigma_m,
                spec.pitch,
                math.radians(params.camera.plane_pitch_sigma_deg),
            )
            spec_values = (spec.K, None, None, spec.roll, spec.yaw)
    return estimate_camera(
        image.width,
        image.height,
        *spec_values,
        height_observations(objects, catalogue, table, image.width),
        road_top_row(_label_mask(seg, "road"), params.scene),
        vanishing=vanishing,  # the photo's own lines measure the horizon when the pitch is not given
        params=params.camera,
        focal=focal,
        pose_prior=pose_prior,
        lanes=lanes,
        roll_measurement=roll,
    )


def _ground_fit(request: BuildRequest, camera: PinholeCamera, params: Parameters) -> tuple[HomographyFit, str]:
    if request.correspondences is not None:
        from usdworld.io.correspondences import read_correspondences

        pairs = read_correspondences(request.correspondences)
        return estimate_homography(pairs.points_px, pairs.points_ground), "manual"
    px, ground = ground_correspondences(camera, params.scene.dlt_grid, params.scene.dlt_horizon_margin)
    return estimate_homography(px, ground), "camera_model"


def _inputs(request: BuildRequest, head: SceneHead) -> tuple[InputFile, ...]:
    """Every input file with its digest, for the provenance."""
    inputs = [head.image.file]
    if head.seg is not None:
        inputs.extend(head.seg.files)
    for path, role in ((request.detections, "detections"), (request.correspondences, "correspondences")):
        if path is not None:
            inputs.append(read_input(path, role)[1])
    if request.detection_items is not None:
        inputs.append(request.detection_items.file)
    if head.spec is not None:
        inputs.append(head.spec.file)
        inputs.extend(head.spec.extra_files)
    if request.depth_map is not None:
        inputs.append(read_input(request.depth_map, "depth_map")[1])
    return tuple(inputs)


def _warnings(head: SceneHead, skipped: list[Skipped], max_range_m: float, params: Parameters) -> tuple[str, ...]:
    warnings = []
    if not head.objects:
        warnings.append(f"{head.image.file.name}: no objects found; the world has ground and camera only")
    warnings.extend(skip_warnings(skipped, max_range_m, params.collision))
    if head.inference_warning:
        warnings.append(head.inference_warning)
    if head.camera.estimated:
        warnings.append(f"camera estimated ({', '.join(head.camera.estimated)}): {head.camera.method}")
    return tuple(warnings)


# --- stages ---------------------------------------------------------------------------


def read_scene_head(
    request: BuildRequest, libraries: tuple[Path, ...], table: ClassTable, params: Parameters
) -> SceneHead:
    """The shared head of a build: inputs, vanishing point, objects, asset catalogue, camera.

    Args:
        request: the inputs.
        libraries: asset libraries, user first.
        table: the class table.
        params: the parameters used.
    """
    with StageThreads(request.threads) as stages:
        # The photo is decoded and its street lines found (they need the photo only) while the
        # label maps are decoded and the other inputs read.
        image_done = stages.submit(read_image, request.image)
        lines = stages.submit(_image_lines, image_done, params.camera)
        with earlier_errors_first(image_done):
            seg = _read_segmentation(request, image_done)
        image = image_done.result()
        spec = request.camera_spec
        if spec is None and request.camera is not None:
            spec = read_camera(request.camera, image, request.ground_plane)
        dets = _read_detections(request, image)
        if request.segment != "none":  # the model runs once every input file has been read and checked
            from usdworld.segment_stage import segment_photo

            seg = segment_photo(request.segment, request.segment_model, image, dets, params.perception)
        with earlier_errors_first(lines):
            # The label map's regions need no perspective: found while the lines are.
            regions = segment_regions(seg, table, label_lookups(), params.perception) if seg is not None else None
        segments, vanishing = lines.result()
    view = street_view(spec, image.width, image.height, vanishing, params.placement.curb_height_m, params.camera)
    objects = _objects(dets, image, seg, view, table, params, regions)
    catalogue = asset_catalogue((o.class_name for o in objects), libraries)
    focal = None
    no_intrinsics = spec is None or spec.K is None
    no_roll = spec is None or spec.roll is None
    # The poles' and building edges' vanishing point, found once: the focal length and the roll use it.
    vertical = (
        find_vertical_vanishing_point(segments, image.width, image.height, params.camera)
        if no_intrinsics or no_roll
        else None
    )
    if no_intrinsics:  # the photo's own cues (EXIF, lines, vehicles)
        from usdworld.io.exif import read_exif_focal
        from usdworld.layout.focal_cues import estimate_focal

        exif = read_exif_focal(request.image, image.width, image.height)
        focal = estimate_focal(
            image.width, image.height, objects, table, vanishing, segments, vertical, exif, params.camera
        )
    lanes = None
    if params.camera.lane_height_cue:
        from usdworld.geometry.lanes import find_lane_markings

        lanes = find_lane_markings(
            image.rgb,
            vanishing,
            np.array([o.box_px for o in objects if o.is_thing], dtype=np.float64).reshape(-1, 4),
            _label_mask(seg, "road"),
            params.camera,
        )
    roll = None
    if no_roll and vertical is not None:  # no roll given: the photo's verticals measure it
        from usdworld.geometry.roll import roll_from_vertical

        roll = roll_from_vertical(vertical, image.width, image.height, params.camera)
    camera = _camera(spec, image, objects, seg, catalogue, vanishing, table, params, focal, lanes, roll)
    inferred, why = None, ""
    boxes_given = request.detections is not None or request.detection_items is not None
    if seg is None and boxes_given and request.infer_streets:
        # Boxes only: the road, sidewalks and buildings from the photo, once the camera gives the horizon.
        from usdworld.perception.refs import join_things_and_stuff
        from usdworld.streets_stage import inferred_stuff, infer_streets

        inferred, why = infer_streets(image, objects, camera.camera, vanishing, table, params)
        if inferred is not None:
            seg = Segmentation(inferred.label_ids, None, ())
            objects = join_things_and_stuff(objects, inferred_stuff(seg, view, table, params), params.perception)
            catalogue = asset_catalogue((o.class_name for o in objects), libraries)
    return SceneHead(image, seg, spec, vanishing, objects, catalogue, camera, inferred, why)


def _street_lines(
    image: SourceImage, params: CameraParams
) -> tuple[np.ndarray, VanishingPoint | None]:
    """The photo's line segments (``detect_segments``) and the street's vanishing point from them."""
    segments = detect_segments(image.rgb, params)
    return segments, find_vanishing_point(segments, image.width, image.height, params)


def _image_lines(
    image: Future[SourceImage], params: CameraParams
) -> tuple[np.ndarray, VanishingPoint | None]:
    """:func:`_street_lines` of the photo, once it is decoded."""
    return _street_lines(image.result(), params)


def depth_for_image(request: BuildRequest) -> tuple[DepthOutcome, PinholeCamera]:
    """Only the depth stage of a build: the metric depth and the camera it used."""
    head = read_scene_head(
        request, asset_library.library_dirs(request.library), load_class_table(), request.parameters
    )
    outcome = estimate_depth(
        request.depth,
        request.depth_weights,
        request.depth_map,
        head.image,
        head.camera.camera,
        head.seg,
        head.objects,
        request.parameters.perception,
    )
    return outcome, head.camera.camera


@dataclass(frozen=True)
class PerceivedView:
    """A photo's work up to the placement: what :func:`place_view` places (picklable).

    Everything here is read or measured from the inputs with ``params`` and none of it
    depends on the placement section but its curb height (the street view's facades read it),
    so one photo can be placed again with other placement numbers (a camera rig widens the
    contact cues by the ground's spread its views measure, :mod:`usdworld.views.build`)
    without decoding, perceiving or estimating anything again.

    Attributes:
        params: the parameters the photo was perceived with (``BuildRequest.parameters``).
        head: the inputs, vanishing point, image objects, asset catalogue and camera.
        dense: the dense depth and how it was made metric.
        fit: the ground homography.
        dlt_source: where its correspondences came from, ``manual`` or ``camera_model``.
        inputs: every input file with its digest, for the provenance.
        traffic: the side traffic keeps to.
        threads: the threads :func:`finish_view` runs its independent stages on
            (``BuildRequest.threads``).
    """

    params: Parameters
    head: SceneHead = field(repr=False)
    dense: DepthOutcome = field(repr=False)
    fit: HomographyFit = field(repr=False)
    dlt_source: str
    inputs: tuple[InputFile, ...]
    traffic: str
    threads: int = 1


def perceive(request: BuildRequest, libraries: tuple[Path, ...]) -> PerceivedView:
    """Read the inputs and do a photo's work up to the placement (no output written).

    Args:
        request: the inputs.
        libraries: asset libraries, user first.

    Returns:
        What :func:`place_view` places.
    """
    params = request.parameters
    head = read_scene_head(request, libraries, load_class_table(), params)
    camera = head.camera.camera
    dense = estimate_depth(
        request.depth,
        request.depth_weights,
        request.depth_map,
        head.image,
        camera,
        head.seg,
        head.objects,
        params.perception,
    )
    fit, dlt_source = _ground_fit(request, camera, params)
    return PerceivedView(
        params, head, dense, fit, dlt_source, _inputs(request, head), request.traffic, request.threads
    )


@dataclass(frozen=True)
class PlacedView:
    """A perceived photo's objects placed: what :func:`finish_view` completes to a world (picklable).

    Attributes:
        perceived: the photo's work up to the placement.
        params: the parameters placed with: the perceived ones with the placement section given
            to :func:`place_view`.
        axis: the road axis.
        placements: the placed objects, in the objects' order.
        skipped: the objects that could not be placed.
    """

    perceived: PerceivedView = field(repr=False)
    params: Parameters = field(repr=False)
    axis: RoadAxis
    placements: tuple[Placement, ...]
    skipped: tuple[Skipped, ...]


def place_view(perceived: PerceivedView, placement: PlacementParams | None = None) -> PlacedView:
    """Place a perceived photo's objects: the road axis and the placements.

    Args:
        perceived: the photo's work up to the placement (:func:`perceive`).
        placement: the placement numbers to place with; None for those it was perceived with.

    Returns:
        The placed view (:func:`finish_view` makes its world).

    Raises:
        ValueError: ``placement`` has another curb height than the one the photo was
            perceived with (the street view read it before the placement).
    """
    params = perceived.params
    if placement is not None:
        if placement.curb_height_m != params.placement.curb_height_m:
            raise ValueError(
                f"placement.curb_height_m {placement.curb_height_m} differs from the "
                f"{params.placement.curb_height_m} the photo was perceived with; perceive it again"
            )
        params = dataclasses.replace(params, placement=placement)
    head, fit = perceived.head, perceived.fit
    max_range_m = params.scene.max_range_m
    camera = head.camera.camera
    stride = params.scene.surface_stride_px
    road = _label_mask(head.seg, "road")
    sidewalk = _label_mask(head.seg, "sidewalk")
    # An inferred road is grown from the vehicles' own contacts, so it says nothing about the
    # road's direction or centre line that the vehicles do not: the axis reads given labels only.
    axis_road = road if head.inferred is None else None
    axis = road_axis(
        surface_points(axis_road, fit.dst_from_src, camera, max_range_m, stride) if axis_road is not None else None,
        vanishing_angle=vanishing_yaw(head.vanishing, camera),
        params=params.placement,
        traffic=perceived.traffic,
    )
    placements, skipped = place_objects(
        head.objects,
        camera,
        fit.dst_from_src,
        axis,
        head.catalogue,
        load_class_table(),
        params.placement,
        perceived.dense.depth_map,
        camera_sigma=(head.camera.sigma_height_m, head.camera.sigma_pitch),
        max_partial_depth_m=max_range_m,
        sidewalk_ground=surface_points(sidewalk, fit.dst_from_src, camera, max_range_m, stride)
        if sidewalk is not None
        else None,
        collision=params.collision,
        perception=params.perception,
    )
    return PlacedView(perceived, params, axis, tuple(placements), tuple(skipped))


def finish_view(placed: PlacedView) -> WorldModel:
    """What follows from the placements: the ground surfaces, the light (the placed objects'
    shadows), the colours measured for that light, and the metric world.

    The surfaces and the colours measured in the photo need no light: with
    ``placed.perceived.threads`` > 1 they are made on a helper thread while this one estimates
    the light (:mod:`usdworld.stage_threads`).

    Args:
        placed: the placed view (:func:`place_view`).

    Returns:
        The world model.
    """
    perceived, params, placements = placed.perceived, placed.params, list(placed.placements)
    head, fit = perceived.head, perceived.fit
    max_range_m = params.scene.max_range_m
    table = load_class_table()
    camera = head.camera.camera
    surface_ids = {name: [label_lookups().id_of(c) for c in classes] for name, classes in SURFACE_CLASSES.items()}
    with StageThreads(perceived.threads) as stages:
        # The ground surfaces and the colours need no light: measured while the light is estimated.
        surfaces_done = stages.submit(_surfaces, placed, surface_ids)
        colours_done = stages.submit(_colours, placed, surfaces_done, surface_ids)
        with earlier_errors_first(surfaces_done):
            light = estimate_scene_light(
                head.image, head.seg, placements, camera, fit.dst_from_src, table, params.light
            )
        surfaces = surfaces_done.result()
        colours = colours_done.result()
    lighting = world_lighting(light)
    appearances = appearances_for(colours, placements, camera, lighting)
    dense = perceived.dense
    return WorldModel(
        image_name=head.image.file.name,
        image_size=(head.image.width, head.image.height),
        camera=head.camera,
        ground_fit=fit,
        dlt_source=perceived.dlt_source,
        placements=placed.placements,
        surfaces=tuple(surfaces),
        inputs=perceived.inputs,
        depth_source=dense.source,
        depth_kind=dense.kind,
        depth_alignment=dense.alignment,
        depth_fit=dense.fit,
        warnings=_warnings(head, list(placed.skipped), max_range_m, params),
        appearances=appearances,
        light=light,
        lights=light_rig(lighting),
    )


def _surfaces(placed: PlacedView, surface_ids: dict[str, list[int]]) -> list[SurfaceMesh]:
    """The ground surfaces of a placed view (the labels' ground, filled where objects hide it)."""
    head, params = placed.perceived.head, placed.params
    camera = head.camera.camera
    filled = None
    if head.seg is not None:
        filled = fill_hidden_ground(
            np.asarray(head.seg.label_ids),
            list(placed.placements),
            camera,
            placed.axis.angle,
            load_class_table(),
            params.scene,
        )
    return build_surfaces(
        filled,
        surface_ids,
        camera,
        placed.perceived.fit.dst_from_src,
        params.placement.curb_height_m,
        params.scene.max_range_m,
    )


def _colours(
    placed: PlacedView, surfaces: Future[list[SurfaceMesh]], surface_ids: dict[str, list[int]]
) -> PhotoColours:
    """The colours measured in the photo for a placed view's objects and its ``surfaces``, once made."""
    head = placed.perceived.head
    return photo_colours(
        head.image,
        head.seg,
        placed.placements,
        surfaces.result(),
        {**surface_ids, "terrain": [label_lookups().id_of("terrain")]},
        head.camera.camera,
        placed.params.perception,
        labels_inferred=head.inferred is not None,
    )


def build_model(request: BuildRequest, libraries: tuple[Path, ...]) -> WorldModel:
    """Read the inputs and compute the metric world (no output written).

    Args:
        request: the inputs.
        libraries: asset libraries, user first.

    Returns:
        The world model: :func:`finish_view` of :func:`place_view` of :func:`perceive`.
    """
    return finish_view(place_view(perceive(request, libraries)))


# --- output ---------------------------------------------------------------------------


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
        InputError: the photo alone: no labels, polygons, detections or segmentation backend
            (:func:`require_object_source`).
        UsdWorldError: any bad input (InputError, CalibrationError ...) or an unwritable output.
    """
    require_object_source(request)
    out = Path(request.output)
    keep_edits = _prepare_output(out)
    libraries = asset_library.library_dirs(request.library)
    model = build_model(request, libraries)
    asset_files = asset_library.asset_files((p.obj.class_name for p in model.placements), libraries)
    report = make_report(model, request.parameters)
    try:
        tmp = Path(tempfile.mkdtemp(prefix=temporary_prefix(out), dir=out.parent))
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
