"""Find the frames of a dataset: Cityscapes trees, KITTI object trees and manifests.

Every ``discover_*`` function is a generator: it lists folders (or reads manifest rows) one
at a time and yields a :class:`~usdworld.batch.frames.Frame` per complete frame and an
:class:`~usdworld.batch.frames.Incomplete` (with the reason) per file or frame it will not
build. It only checks that files exist; no image is opened, so a tree of thousands of
frames streams in constant memory. Paths in the frames are absolute.

Layouts:

* ``cityscapes``: ``ROOT/leftImg8bit/<split>/<city>/<name>_leftImg8bit.png`` with
  ``ROOT/gtFine/<split>/<city>/<name>_gtFine_labelIds.png`` and ``..._instanceIds.png``
  (or, when those are absent, ``..._gtFine_polygons.json``), and optionally
  ``ROOT/camera/<split>/<city>/<name>_camera.json`` (without it the camera is estimated).
  The frame id is ``<name>``, e.g. ``frankfurt_000000_000294``.
* ``kitti``: ``ROOT/image_2/<id>.png`` with ``ROOT/label_2/<id>.txt`` and
  ``ROOT/calib/<id>.txt``; with ``ground_plane=True`` also ``ROOT/planes/<id>.txt``.
  ROOT is e.g. ``kitti/object/training``.
* manifest: a JSON list of objects or a CSV file with a header row, one frame per row.
  Keys/columns are ``id`` (optional; default the image's file stem) and the
  :class:`~usdworld.pipeline.BuildRequest` fields ``image`` (required), ``labels``,
  ``instances``, ``polygons``, ``detections``, ``camera``, ``ground_plane``,
  ``correspondences``, ``depth_map``, ``library`` and ``max_range_m``. Relative paths are
  relative to the manifest's folder; empty cells and ``null`` mean "not given". Every row
  asks for its frame, so a row that cannot be built (a missing file, a bad value) is an
  :class:`~usdworld.batch.frames.Incomplete` with ``fails=True``: it fails the batch::

      id,image,labels,instances,camera
      f1,img/f1.png,gt/f1_labelIds.png,gt/f1_instanceIds.png,cam/f1.json

* ``views`` and ``nuscenes``: one multi-view world per views manifest or nuScenes sample
  (:mod:`usdworld.batch.views`).

Example:
    >>> for item in discover("cityscapes/", "cityscapes", splits=["val"]):  # doctest: +SKIP
    ...     print(item)
"""

from __future__ import annotations

import csv
import os
from collections.abc import Iterable, Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

from usdworld.batch.frames import Frame, Incomplete, make_frame
from usdworld.errors import InputError
from usdworld.io.camera_infos import split_camera_ref
from usdworld.io.hashing import json_type, parse_json, read_input
from usdworld.io.limits import MAX_RANGE_CAP_M
from usdworld.parameters import DEFAULT_PARAMETERS

MAX_RANGE_M = DEFAULT_PARAMETERS.scene.max_range_m  # the default range (scene.max_range_m)

LAYOUTS = ("cityscapes", "kitti", "manifest", "views", "nuscenes")
IMAGE_SUFFIX = "_leftImg8bit.png"
LABELS_SUFFIX = "_gtFine_labelIds.png"
INSTANCES_SUFFIX = "_gtFine_instanceIds.png"
POLYGONS_SUFFIX = "_gtFine_polygons.json"
CAMERA_SUFFIX = "_camera.json"
KITTI_IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg")
#: Manifest keys: ``id`` plus the BuildRequest fields a row may set.
PATH_FIELDS = (
    "image",
    "labels",
    "instances",
    "polygons",
    "detections",
    "camera",
    "ground_plane",
    "correspondences",
    "depth_map",
    "library",
)
MANIFEST_FIELDS = ("id", *PATH_FIELDS, "max_range_m")

Item = Frame | Incomplete


def _entries(folder: Path) -> list[os.DirEntry[str]]:
    """Sorted entries of a folder, hidden ones left out."""
    try:
        with os.scandir(folder) as it:
            return sorted((e for e in it if not e.name.startswith(".")), key=lambda e: e.name)
    except OSError as exc:
        raise InputError(f"{folder}: cannot list the folder ({exc.strerror or exc})") from exc


def _require_dir(root: Path, sub: str, hint: str) -> Path:
    if not root.is_dir():
        raise InputError(f"{root}: no such folder; {hint}")
    folder = root / sub
    if not folder.is_dir():
        raise InputError(f"{root}: no {sub}/ folder; {hint}")
    return folder


def _unique(items: Iterable[Item]) -> Iterator[Item]:
    """Pass items through, turning a second frame of an already seen id into an Incomplete."""
    seen: dict[str, str] = {}
    for item in items:
        if isinstance(item, Frame):
            first = seen.get(item.frame_id)
            if first is not None:
                yield Incomplete(item.source, f"duplicate frame id {item.frame_id!r} (first from {first})")
                continue
            seen[item.frame_id] = item.source
        yield item


# --- Cityscapes --------------------------------------------------------------------------


def _cityscapes_city(root: Path, split: str, city: str, options: dict[str, Any]) -> Iterator[Item]:
    rel = f"{split}/{city}"
    gt_dir, cam_dir = root / "gtFine" / split / city, root / "camera" / split / city
    gt_names = {e.name for e in _entries(gt_dir)} if gt_dir.is_dir() else set()
    cam_names = {e.name for e in _entries(cam_dir)} if cam_dir.is_dir() else set()
    image_dir = root / "leftImg8bit" / split / city
    names = set()
    for entry in _entries(image_dir) if image_dir.is_dir() else []:
        source = f"leftImg8bit/{rel}/{entry.name}"
        if not entry.name.endswith(IMAGE_SUFFIX) or not entry.is_file():
            yield Incomplete(source, f"not a Cityscapes image (expected <city>_<seq>_<frame>{IMAGE_SUFFIX})")
            continue
        name = entry.name[: -len(IMAGE_SUFFIX)]
        names.add(name)
        labels, instances, polygons = (
            name + s in gt_names for s in (LABELS_SUFFIX, INSTANCES_SUFFIX, POLYGONS_SUFFIX)
        )
        seg: dict[str, Path]
        if labels and instances:
            seg = {"labels": gt_dir / (name + LABELS_SUFFIX), "instances": gt_dir / (name + INSTANCES_SUFFIX)}
        elif polygons:
            seg = {"polygons": gt_dir / (name + POLYGONS_SUFFIX)}
        else:
            if labels:
                reason = (
                    f"no gtFine/{rel}/{name}{INSTANCES_SUFFIX} beside its labelIds (nor {POLYGONS_SUFFIX})"
                )
            elif instances:
                reason = (
                    f"no gtFine/{rel}/{name}{LABELS_SUFFIX} beside its instanceIds (nor {POLYGONS_SUFFIX})"
                )
            else:
                reason = f"no gtFine labels: need gtFine/{rel}/{name}{LABELS_SUFFIX} with {INSTANCES_SUFFIX}, or {POLYGONS_SUFFIX}"
            yield Incomplete(name, reason)
            continue
        camera = cam_dir / (name + CAMERA_SUFFIX) if name + CAMERA_SUFFIX in cam_names else None
        yield make_frame(name, source, image_dir / entry.name, camera=camera, **seg, **options)
    orphans = set()
    for gt_name in gt_names:
        for suffix in (LABELS_SUFFIX, INSTANCES_SUFFIX, POLYGONS_SUFFIX):
            if gt_name.endswith(suffix) and gt_name[: -len(suffix)] not in names:
                orphans.add(gt_name[: -len(suffix)])
    for name in sorted(orphans):
        yield Incomplete(
            name, f"gtFine/{rel} has labels but there is no leftImg8bit/{rel}/{name}{IMAGE_SUFFIX}"
        )


def discover_cityscapes(
    root: str | Path,
    *,
    splits: Iterable[str] = (),
    library: Path | None = None,
    max_range_m: float = MAX_RANGE_M,
) -> Iterator[Item]:
    """Frames of a Cityscapes tree (see the module docstring), in split, city, name order.

    Args:
        root: the folder holding ``leftImg8bit/``, ``gtFine/`` and ``camera/``.
        splits: split folders to read (e.g. ``["val"]``); empty: every split found.
        library: user asset library for every frame.
        max_range_m: farthest ground distance meshed, for every frame.

    Raises:
        InputError: ``root`` or ``root/leftImg8bit`` is missing, or a named split is not there.
    """
    root = Path(root).absolute()
    hint = "pass the Cityscapes root (the folder holding leftImg8bit/, gtFine/ and camera/)"
    images = _require_dir(root, "leftImg8bit", hint)
    found = [e.name for e in _entries(images) if e.is_dir()]
    wanted = list(dict.fromkeys(splits))
    for split in wanted:
        if split not in found:
            raise InputError(f"{images}: no split {split!r}; found {', '.join(found) or 'none'}")
    options = {"library": library, "max_range_m": max_range_m}

    def frames() -> Iterator[Item]:
        for split in wanted or found:
            cities = {e.name for e in _entries(images / split) if e.is_dir()}
            gt_split = root / "gtFine" / split
            if gt_split.is_dir():
                cities |= {e.name for e in _entries(gt_split) if e.is_dir()}
            for city in sorted(cities):
                yield from _cityscapes_city(root, split, city, options)

    return _unique(frames())


# --- KITTI -------------------------------------------------------------------------------


def discover_kitti(
    root: str | Path,
    *,
    ground_plane: bool = False,
    library: Path | None = None,
    max_range_m: float = MAX_RANGE_M,
) -> Iterator[Item]:
    """Frames of a KITTI object tree (see the module docstring), in id order.

    Args:
        root: the folder holding ``image_2/``, ``label_2/`` and ``calib/`` (e.g. ``training``).
        ground_plane: also require ``planes/<id>.txt`` and use it for the camera height and pitch.
        library: user asset library for every frame.
        max_range_m: farthest ground distance meshed, for every frame.

    Raises:
        InputError: ``root`` or ``root/image_2`` is missing.
    """
    root = Path(root).absolute()
    hint = "pass the KITTI object split folder (the one holding image_2/, label_2/ and calib/)"
    image_dir = _require_dir(root, "image_2", hint)
    needed = ["label_2", "calib"] + (["planes"] if ground_plane else [])
    listings = {
        sub: {e.name for e in _entries(root / sub)} if (root / sub).is_dir() else set() for sub in needed
    }
    stems = set()
    options = {"library": library, "max_range_m": max_range_m}

    def frames() -> Iterator[Item]:
        for entry in _entries(image_dir):
            source = f"image_2/{entry.name}"
            stem, suffix = os.path.splitext(entry.name)
            if suffix.lower() not in KITTI_IMAGE_SUFFIXES or not entry.is_file():
                yield Incomplete(source, "not a KITTI image (expected image_2/<id>.png)")
                continue
            stems.add(stem)
            missing = [f"{sub}/{stem}.txt" for sub in needed if f"{stem}.txt" not in listings[sub]]
            if missing:
                yield Incomplete(stem, f"no {' and no '.join(missing)}")
                continue
            files = {sub: root / sub / f"{stem}.txt" for sub in needed}
            yield make_frame(
                stem,
                source,
                image_dir / entry.name,
                detections=files["label_2"],
                camera=files["calib"],
                ground_plane=files.get("planes"),
                **options,
            )
        orphans = {os.path.splitext(n)[0] for n in listings["label_2"] if n.endswith(".txt")} - stems
        for stem in sorted(orphans):
            yield Incomplete(stem, f"label_2/{stem}.txt has no image_2/{stem}.png")

    return _unique(frames())


# --- manifests ---------------------------------------------------------------------------


def _manifest_row(row: dict[str, Any], where: str, base: Path, defaults: dict[str, Any]) -> Item:
    unknown = sorted(set(row) - set(MANIFEST_FIELDS))
    name = str(row.get("id") or row.get("image") or where)
    if unknown:
        return Incomplete(name, f"{where}: unknown field {unknown[0]!r}; use {', '.join(MANIFEST_FIELDS)}")
    values = {k: (None if v is None or (isinstance(v, str) and not v.strip()) else v) for k, v in row.items()}
    image = values.get("image")
    if image is None:
        return Incomplete(name, f"{where}: no image; every row names its photo in 'image'")
    options: dict[str, Any] = dict(defaults)
    for field in PATH_FIELDS:
        value = values.get(field)
        if value is None:
            continue
        if not isinstance(value, str):
            return Incomplete(name, f"{where} -> {field}: must be a path string, got {json_type(value)}")
        path = (base / value.strip()).absolute()
        if field == "library":
            exists = path.is_dir()
        else:  # a camera may be one camera of an info file: info.json#CAM_FRONT
            exists = (split_camera_ref(path)[0] if field == "camera" else path).is_file()
        if not exists:
            return Incomplete(
                name, f"{where} -> {field}: {path}: no such {'folder' if field == 'library' else 'file'}"
            )
        options[field] = path
    max_range = values.get("max_range_m")
    if max_range is not None:
        try:
            options["max_range_m"] = float(max_range)
        except (TypeError, ValueError):
            return Incomplete(name, f"{where} -> max_range_m: must be a number, got {max_range!r}")
        if not 0 < options["max_range_m"] <= MAX_RANGE_CAP_M:
            return Incomplete(
                name, f"{where} -> max_range_m: must be > 0 and <= {MAX_RANGE_CAP_M:g} m, got {max_range!r}"
            )
    frame_id = values.get("id")
    if frame_id is None:
        frame_id = Path(str(image).strip()).stem
    elif not isinstance(frame_id, str):
        return Incomplete(name, f"{where} -> id: must be a string, got {json_type(frame_id)}")
    item = make_frame(frame_id.strip(), str(image).strip(), options.pop("image"), **options)
    if isinstance(item, Incomplete):
        return Incomplete(item.name, f"{where}: {item.reason}")
    return item


def _json_rows(path: Path) -> Iterator[tuple[str, Any]]:
    """Parse and check the document now (a manifest is small: paths, not images)."""
    data, _ = read_input(path, "manifest")
    doc = parse_json(data, path.name)
    if not isinstance(doc, list):
        raise InputError(f"{path.name}: must be a JSON list of frame objects, got {json_type(doc)}")
    return ((f"{path.name} -> [{i}]", row) for i, row in enumerate(doc))


def _csv_rows(path: Path) -> Iterator[tuple[str, Any]]:
    """Check the header now; the rows are read as the returned iterator is consumed."""
    try:
        f = path.open(newline="", encoding="utf-8-sig")
    except OSError as exc:
        raise InputError(f"{path}: cannot read the manifest ({exc.strerror or exc})") from exc
    reader = csv.DictReader(f)
    try:
        header = reader.fieldnames
    except (csv.Error, UnicodeDecodeError) as exc:
        f.close()
        raise InputError(f"{path.name}: not a readable CSV file ({exc})") from exc
    problem = None
    if not header:
        problem = "empty; the first line must name the columns, e.g. id,image,labels,instances,camera"
    elif [c for c in header if c not in MANIFEST_FIELDS]:
        unknown = next(c for c in header if c not in MANIFEST_FIELDS)
        problem = f"unknown column {unknown!r}; use {', '.join(MANIFEST_FIELDS)}"
    elif "image" not in header:
        problem = "no 'image' column; every row names its photo in 'image'"
    if problem:
        f.close()
        raise InputError(f"{path.name}: {problem}")

    def rows() -> Iterator[tuple[str, Any]]:
        with f:
            try:
                for row in reader:
                    where = f"{path.name} line {reader.line_num}"
                    if None in row:
                        yield where, {"__extra__": True}
                    else:
                        yield where, row
            except (csv.Error, UnicodeDecodeError) as exc:
                raise InputError(f"{path.name} line {reader.line_num}: not readable CSV ({exc})") from exc

    return rows()


def discover_manifest(
    path: str | Path, *, library: Path | None = None, max_range_m: float = MAX_RANGE_M
) -> Iterator[Item]:
    """Frames of a JSON or CSV manifest (see the module docstring), in row order.

    Args:
        path: ``*.json`` (a list of objects) or ``*.csv`` (header row, then one row per frame).
        library: user asset library for rows that name none.
        max_range_m: farthest ground distance meshed, for rows that give none.

    Raises:
        InputError: the manifest cannot be read, is not a JSON list, or its CSV header
            names an unknown column or no ``image`` column.
    """
    path = Path(path).absolute()
    if not path.is_file():
        raise InputError(
            f"{path}: no such manifest file; pass a .json or .csv manifest, or a dataset folder with --layout"
        )
    suffix = path.suffix.lower()
    if suffix not in (".json", ".csv"):
        raise InputError(
            f"{path.name}: a manifest is a .json or .csv file; for a dataset folder pass --layout"
        )
    rows = _json_rows(path) if suffix == ".json" else _csv_rows(path)
    defaults = {"library": library, "max_range_m": max_range_m}

    def frames() -> Iterator[Item]:
        for where, row in rows:
            if not isinstance(row, dict):
                yield Incomplete(
                    where, f"{where}: must be an object naming the frame's files, got {json_type(row)}"
                )
            elif "__extra__" in row:
                yield Incomplete(where, f"{where}: more cells than columns")
            else:
                yield _manifest_row(row, where, path.parent, defaults)

    # Every row asks for its frame: one that cannot be built is a failure, not a stray file.
    return (replace(item, fails=True) if isinstance(item, Incomplete) else item for item in _unique(frames()))


# --- dispatch ----------------------------------------------------------------------------


def resolve_layout(source: Path, layout: str | None) -> str:
    """The layout to read ``source`` with: ``layout`` itself, or ``manifest`` for a .json/.csv file.

    Raises:
        InputError: an unknown layout, a folder without ``--layout``, or a manifest layout for a folder.
    """
    if layout is not None:
        if layout not in LAYOUTS:
            raise InputError(f"--layout {layout}: unknown; use one of {', '.join(LAYOUTS)}")
        return layout
    if source.is_dir():
        found = [sub for sub in ("leftImg8bit", "image_2") if (source / sub).is_dir()]
        hint = {"leftImg8bit": "--layout cityscapes", "image_2": "--layout kitti"}
        suggestion = f" (it holds {found[0]}/: {hint[found[0]]})" if found else ""
        raise InputError(f"{source}: a folder; pass --layout cityscapes or --layout kitti{suggestion}")
    return "manifest"


def discover(
    source: str | Path,
    layout: str | None = None,
    *,
    splits: Iterable[str] = (),
    ground_plane: bool = False,
    library: Path | None = None,
    max_range_m: float = MAX_RANGE_M,
) -> Iterator[Item]:
    """Frames of ``source`` read with ``layout`` (see :func:`resolve_layout`).

    Args:
        source: dataset root or manifest file.
        layout: ``cityscapes``, ``kitti``, ``manifest``, ``views``, ``nuscenes``
            (:mod:`usdworld.batch.views`) or None (manifest for a file).
        splits: Cityscapes splits (cityscapes only).
        ground_plane: use KITTI ``planes/`` (kitti only).
        library: user asset library (rows of a manifest may name their own).
        max_range_m: farthest ground distance meshed (rows of a manifest may give their own).

    Raises:
        InputError: the source cannot be read with the layout, or an option does not apply to it.
    """
    source = Path(source)
    layout = resolve_layout(source, layout)
    splits = list(splits)
    if splits and layout != "cityscapes":
        raise InputError("--split applies to --layout cityscapes only")
    if ground_plane and layout != "kitti":
        raise InputError("--ground-plane applies to --layout kitti only")
    if not 0 < max_range_m <= MAX_RANGE_CAP_M:
        raise InputError(
            f"--max-range must be > 0 and <= {MAX_RANGE_CAP_M:g} m (the ground is meshed out to it), "
            f"got {max_range_m:g}"
        )
    if layout == "cityscapes":
        return discover_cityscapes(source, splits=splits, library=library, max_range_m=max_range_m)
    if layout == "kitti":
        return discover_kitti(source, ground_plane=ground_plane, library=library, max_range_m=max_range_m)
    if layout in ("views", "nuscenes"):  # one multi-view world per views manifest or nuScenes sample
        from usdworld.batch.views import discover_nuscenes, discover_views

        find = discover_views if layout == "views" else discover_nuscenes
        return _unique(find(source, library=library, max_range_m=max_range_m))
    return discover_manifest(source, library=library, max_range_m=max_range_m)


def count_frames(items: Iterable[Item]) -> tuple[int, list[Incomplete]]:
    """Consume a discovery stream and count it (a quick pass: no image is read).

    Returns:
        The number of frames, and the incomplete entries.
    """
    frames, incomplete = 0, []
    for item in items:
        if isinstance(item, Frame):
            frames += 1
        else:
            incomplete.append(item)
    return frames, incomplete
