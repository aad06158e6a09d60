"""Batches of multi-view worlds: views manifests (``--layout views``) and nuScenes samples (``--layout nuscenes``).

Each views manifest, or each sample of an mmdetection3d nuScenes info file, is one job of
the batch: one world ``OUT/<frame_id>/`` built by :func:`usdworld.views.build.build_views`,
exactly as ``usdworld build --views`` (with ``--jobs 1``: the batch's workers are the
parallelism, and a pool's worker process may not start processes of its own).

* ``views``: SOURCE is a views manifest, or a folder whose ``*.json`` files that are views
  manifests (a JSON object with a ``views`` key) are the jobs, in name order; the other
  JSON files there (the views' camera files and detections) are not jobs. The frame id is
  the manifest's file stem.
* ``nuscenes``: SOURCE is an info JSON; every sample of its ``data_list`` is a job, with the
  sample's token as the frame id (``sample_<index>`` for a sample without one). A sample
  whose photos are not beside the info file is listed as incomplete. SOURCE may also be a
  nuScenes dataroot (``build --dataroot``): every sample of its tables is a job (each job
  loads the tables through nuscenes-devkit again: seconds for v1.0-mini, far longer for
  v1.0-trainval).

Discovery reads the manifests and the info file (small JSON), never a photo; the views are
read by the worker (:meth:`ViewsBuild.build`). A job's resume key
(:func:`views_key`) hashes every file its views name, as a single frame's key does.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import usdworld
from usdworld.batch.frames import Frame, Incomplete, check_frame_id
from usdworld.batch.resume import KEY_FORMAT, file_digest, folder_digest
from usdworld.errors import InputError, UsdWorldError
from usdworld.io.hashing import json_type
from usdworld.parameters import DEFAULT_PARAMETERS

#: The batch layouts of multi-view worlds.
VIEWS_LAYOUTS = ("views", "nuscenes")


@dataclass(frozen=True)
class ViewsBuild:
    """One multi-view world of a batch: what ``usdworld build --views`` is given. Picklable.

    Attributes:
        views: the views manifest or the nuScenes info JSON.
        layout: ``manifest`` or ``nuscenes`` (as ``build --layout``).
        sample: the nuScenes sample's token (None: the first sample; always None for a manifest).
        output: the world folder (relative ``Path(frame_id)`` in a :class:`Frame`).
        library: a user asset library, or None.
        max_range_m: farthest ground distance meshed, metres.
    """

    views: Path
    layout: str
    sample: str | None
    output: Path
    library: Path | None = None
    max_range_m: float = field(default=DEFAULT_PARAMETERS.scene.max_range_m)

    def build(self) -> Any:
        """Build the world as ``build --views ... --jobs 1`` does.

        Returns:
            The :class:`~usdworld.pipeline.BuildResult`.

        Raises:
            UsdWorldError: a bad manifest or info file, or any error of the build.
        """
        from usdworld.views.build import ViewsRequest, build_views, read_view_set

        views = read_view_set(self.views, self.layout, self.sample)
        return build_views(
            ViewsRequest(views, self.output, library=self.library, max_range_m=self.max_range_m, jobs=1)
        )


def views_key(request: ViewsBuild) -> str:
    """The resume key of a multi-view job: 64 hex characters.

    It hashes the key format, the usdworld version, the layout, sample and range, the
    library's files, the manifest or info file, and every file its views name (photo,
    camera file, labels, instances, polygons, detections). When the views cannot be read,
    the key still differs from any readable state (the build then fails with the reason).
    """
    from usdworld.views.build import read_view_set

    doc: dict[str, object] = {
        "format": KEY_FORMAT,
        "usdworld": usdworld.__version__,
        "kind": "views",
        "layout": request.layout,
        "sample": request.sample,
        "max_range_m": repr(request.max_range_m),
        "views": file_digest(request.views),
        "library": folder_digest(request.library) if request.library is not None else None,
    }
    try:
        view_set = read_view_set(request.views, request.layout, request.sample)
    except UsdWorldError as exc:
        doc["unreadable"] = str(exc)
    else:
        doc["source"] = view_set.source.sha256  # a dataroot's tables
        doc["files"] = [
            {
                name: file_digest(path)
                for name in ("image", "camera", "labels", "instances", "polygons", "detections")
                if (path := getattr(view, name)) is not None
            }
            for view in view_set.views
        ]
    return hashlib.sha256(json.dumps(doc, sort_keys=True).encode()).hexdigest()


def _frame(frame_id: str, source: str, request: ViewsBuild) -> Frame | Incomplete:
    try:
        check_frame_id(frame_id)
        return Frame(frame_id, source, request)  # type: ignore[arg-type]
    except InputError as exc:
        return Incomplete(frame_id, str(exc))


def _dataroot_samples(root: Path, library: Path | None, max_range_m: float) -> Iterator[Frame | Incomplete]:
    """One job per sample of a nuScenes dataroot's tables, in the sample table's order.

    Raises:
        InputError: the devkit is missing or cannot load the tables.
    """
    from usdworld.views.nuscenes_devkit import load_devkit

    version, nusc = load_devkit(root, None)

    def frames() -> Iterator[Frame | Incomplete]:
        for sample in nusc.sample:
            token = str(sample["token"])
            request = ViewsBuild(root, "nuscenes", token, Path(token), library, max_range_m)
            yield _frame(token, f"{version}/sample.json#{token}", request)

    return frames()


def _beside(info: Path, img_path: object) -> Path:
    """Where a sample's photo is read from: its file name beside the info file (as ``build`` reads it)."""
    return info.parent / Path(str(img_path or "")).name


def _is_views_manifest(path: Path) -> bool:
    """Whether a JSON file is a views manifest (an object with a ``views`` key); False when unreadable."""
    try:
        doc = json.loads(path.read_bytes())
    except (OSError, ValueError):
        return False
    return isinstance(doc, dict) and "views" in doc


def discover_views(
    source: str | Path, *, library: Path | None = None, max_range_m: float
) -> Iterator[Frame | Incomplete]:
    """One job per views manifest: SOURCE itself when a file, else its ``*.json`` views manifests.

    Raises:
        InputError: SOURCE is neither a file nor a folder.
    """
    source = Path(source).absolute()
    if source.is_file():
        manifests = [source]
        base = source.parent
    elif source.is_dir():
        manifests = [p for p in sorted(source.glob("*.json")) if p.is_file() and _is_views_manifest(p)]
        base = source
    else:
        raise InputError(f"{source}: no such file or folder; pass a views manifest or a folder of them")

    def frames() -> Iterator[Frame | Incomplete]:
        for path in manifests:
            request = ViewsBuild(path, "manifest", None, Path(path.stem), library, max_range_m)
            yield _frame(path.stem, path.relative_to(base).as_posix(), request)

    return frames()


def discover_nuscenes(
    source: str | Path, *, library: Path | None = None, max_range_m: float
) -> Iterator[Frame | Incomplete]:
    """One job per sample of an mmdetection3d nuScenes info JSON (photos beside it).

    Raises:
        InputError: the file cannot be read, is a pickle, or has no ``data_list`` list.
    """
    from usdworld.views.nuscenes import read_info_document

    path = Path(source).absolute()
    if path.is_dir():
        return _dataroot_samples(path, library, max_range_m)
    if not path.is_file():
        raise InputError(
            f"{path}: no such file or folder; --layout nuscenes takes an mmdetection3d info JSON or a nuScenes dataroot"
        )
    doc, file = read_info_document(path)
    samples = doc["data_list"]
    if not isinstance(samples, list):
        raise InputError(f"{file.name}: data_list must be a list of samples, got {json_type(samples)}")

    def frames() -> Iterator[Frame | Incomplete]:
        for i, sample in enumerate(samples):
            where = f"{file.name} -> data_list[{i}]"
            if not isinstance(sample, dict):
                yield Incomplete(where, f"must be a sample object, got {json_type(sample)}")
                continue
            token = sample.get("token")
            frame_id = str(token) if isinstance(token, str) and token else f"sample_{i:04d}"
            images = sample.get("images")
            if not isinstance(images, dict) or not images:
                yield Incomplete(frame_id, f"{where}: no cameras (images is missing or empty)")
                continue
            missing = [
                str(cam)
                for cam, entry in images.items()
                if not (isinstance(entry, dict) and _beside(path, entry.get("img_path")).is_file())
            ]
            if missing:
                yield Incomplete(frame_id, f"{where}: no photo of {', '.join(missing)} beside {file.name}")
                continue
            sample_token = str(token) if isinstance(token, str) and token else None
            if sample_token is None and i > 0:
                yield Incomplete(frame_id, f"{where}: no token; --sample picks samples by token")
                continue
            request = ViewsBuild(path, "nuscenes", sample_token, Path(frame_id), library, max_range_m)
            yield _frame(frame_id, f"{file.name}#{frame_id}", request)

    return frames()
