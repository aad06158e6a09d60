"""One world opened for editing from the web page: JSON views, the scene as GLB, and the edits.

A :class:`WorldSession` owns one :class:`~usdworld.authoring.edits.WorldEditor`, so every
edit goes through the same lock, permissibility rules, history and atomic save as
``usdworld edit``; a refused edit raises the engine's :class:`~usdworld.errors.EditRefused`
(nothing written) and the app words its reason for the page. The editor is not thread-safe: the session
serialises its calls with a lock (the web server runs them in worker threads).

**Version.** :meth:`WorldSession.version` hashes the (inode, mtime, size) of the root, base
and edits layers: it changes whenever anyone, the page or ``usdworld edit`` in a shell,
saves the edits layer (saves are atomic renames) or the world is rebuilt. The page polls it
and re-reads the world when it changes. Snapshots take the version *before* reading the
layers, so a change racing a read is seen by the next poll, never lost.

**Redo** lives here, not in the engine: an undo made through the session pushes the undone
history entries on a redo stack, and a redo replays the newest of them through the engine
(same operation and arguments; ``force`` as it was recorded). The stack is dropped by any
other edit made through the session, and is void once the edits layer's bytes differ from
what the last undo or redo left (someone else edited meanwhile).
"""

from __future__ import annotations

import hashlib
import logging
import math
import threading
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np

from usdworld.authoring import asset_library
from usdworld.authoring.edits import EditResult, HistoryEntry, ObjectState, WorldEditor, utc_now
from usdworld.authoring.provenance import read_values
from usdworld.authoring.world import CAMERA_PATH, WORLD_PATH
from usdworld.errors import InputError
from usdworld.layout.permissible import surface_at
from usdworld.serve.payloads import EditRequest

log = logging.getLogger(__name__)

#: Near and far clip distances of the page's camera, metres.
NEAR_M, FAR_M = 0.1, 3000.0
#: Image width assumed when a world records no image size.
FALLBACK_WIDTH_PX = 1024
#: History entries sent to the page (newest last).
HISTORY_SHOWN = 200
#: Photo file types the session serves.
PHOTO_SUFFIXES = {".png": "image/png", ".jpg": "image/jpeg", ".jpeg": "image/jpeg"}
#: File types ``/api/files`` serves from the world folder (layers, assets, photos, reports).
SERVED_SUFFIXES = {".usda", ".usdc", ".usd", ".usdz", ".png", ".jpg", ".jpeg", ".json"}
#: Provenance attributes sent per object (``usdworld:<name>`` -> JSON key).
PROVENANCE_KEYS = {
    "sourceImage": "source_image",
    "sourceClass": "source_class",
    "instanceId": "instance_id",
    "imageBBox": "image_bbox_px",
    "groundContactPixel": "contact_px",
    "maskArea": "mask_area_px",
    "bottomTruncated": "bottom_truncated",
    "bottomOccluded": "bottom_occluded",
    "depth": "depth_m",
    "depthMethod": "depth_method",
    "scaleFactor": "scale_factor",
    "scaleMeasured": "scale_measured",
    "yawSource": "yaw_source",
    "collisionDisplacement": "collision_displacement_m",
    "confidence": "confidence",
}
#: Scene attributes of ``/World`` sent to the page.
SCENE_KEYS = {
    "sourceImage": "source_image",
    "imageSize": "image_size_px",
    "intrinsicsEstimated": "intrinsics_estimated",
    "cameraHeight": "camera_height_m",
    "cameraPitch": "camera_pitch_rad",
    "cameraRoll": "camera_roll_rad",
    "cameraMethod": "camera_method",
    "cameraEstimated": "camera_estimated",
    "dltRmsPx": "dlt_rms_px",
    "dltSource": "dlt_source",
    "depthSource": "depth_source",
    "depthKind": "depth_kind",
    "depthAlignment": "depth_alignment",
    "version": "usdworld_version",
}


def jsonable(value: Any) -> Any:
    """A USD/numpy value as JSON data: vectors and arrays as lists, NaN and inf as None."""
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        v = float(value)
        return v if math.isfinite(v) else None
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, Iterable):
        return [jsonable(v) for v in value]
    if hasattr(value, "__len__") and hasattr(value, "__getitem__"):  # Gf vectors
        return [jsonable(value[i]) for i in range(len(value))]
    return str(value)


def _column_major(m: np.ndarray) -> list[float]:
    """(4, 4) column-vector matrix -> 16 floats in three.js ``Matrix4.fromArray`` order."""
    return [float(v) for v in np.asarray(m, dtype=np.float64).T.ravel()]


def object_json(state: ObjectState, surface: str, values: dict[str, Any]) -> dict[str, Any]:
    """One object as the page shows it: state, surface and provenance."""
    prov = {key: jsonable(values.get(f"usdworld:{attr}")) for attr, key in PROVENANCE_KEYS.items()}
    names = list(values.get("usdworld:depthCueNames", []))
    depths = list(values.get("usdworld:depthCueValues", []))
    sigmas = list(values.get("usdworld:depthCueSigmas", []))
    prov["depth_cues"] = [
        {
            "name": str(n),
            "depth_m": jsonable(depths[i]) if i < len(depths) else None,
            "sigma_m": jsonable(sigmas[i]) if i < len(sigmas) else None,
        }
        for i, n in enumerate(names)
    ]
    # a multi-view world's object: its box in each view that saw it (the first, for a view seen twice)
    view_bboxes: dict[str, Any] = {}
    for view, box in zip(values.get("usdworld:views", []), values.get("usdworld:viewBBoxes", [])):
        view_bboxes.setdefault(str(view), jsonable(box))
    prov["view_bboxes_px"] = view_bboxes
    return {
        "name": state.name,
        "path": state.path,
        "class": state.class_name,
        "variant": state.variant,
        "position_m": jsonable(state.position_world),
        "yaw_deg": jsonable(state.yaw_deg),
        "scale": jsonable(state.scale),
        "size_lw_m": jsonable(state.size_lw),
        "active": state.active,
        "status": state.status,
        "color": state.color,
        "surface": surface,
        "depth_m": prov["depth_m"],
        "depth_method": prov["depth_method"] or "",
        "provenance": prov,
    }


def history_json(entry: HistoryEntry) -> dict[str, Any]:
    """One history entry as JSON."""
    return {
        "step": entry.step,
        "op": entry.op,
        "name": str(entry.args.get("name", "")),
        "args": jsonable(entry.args),
        "time": entry.time,
        "forced": entry.forced,
        "violations": list(entry.violations),
    }


def find_view_photo(folder: Path, image: str) -> Path | None:
    """A view's photo of a multi-view world: in the world folder, else the folder above
    (where ``build --views`` leaves the manifest's photos when the world is built beside it),
    as ``render --camera NAME`` finds it. Only a plain PNG or JPEG file name is looked up.
    """
    name = Path(image).name
    if not image or name != image or Path(name).suffix.lower() not in PHOTO_SUFFIXES:
        return None
    for directory in (folder, folder.parent):
        if (directory / name).is_file():
            return directory / name
    return None


def find_photo(folder: Path, source_image: str) -> Path | None:
    """The world's source photo: ``<world folder>/<source image name>``, else the bundled demo's.

    Only a plain file name is looked up (a recorded name with folders in it is ignored), and
    only inside the world folder, or in the package's demo data for the bundled demo world.
    """
    name = Path(source_image).name
    if not source_image or name != source_image or Path(name).suffix.lower() not in PHOTO_SUFFIXES:
        return None
    candidate = folder / name
    if candidate.is_file():
        return candidate
    from usdworld.demo import demo_dir

    bundled = demo_dir() / name
    return bundled if bundled.is_file() else None


class WorldSession:
    """A world opened for editing by the web page.

    Args:
        world: the root layer (``world.usda``) or the world folder.
        photo: the source photo to show; default: found by :func:`find_photo`.
        surface_rules: a surface rule table (as for ``usdworld edit``).
        replacement_rules: a replacement rule table.
        library: a user asset library for classes the world has no asset for yet.
        clock: the history's clock.

    Raises:
        InputError: not a world, or ``photo`` is not a PNG or JPEG file.
    """

    def __init__(
        self,
        world: Path | str,
        *,
        photo: Path | str | None = None,
        surface_rules: Path | str | None = None,
        replacement_rules: Path | str | None = None,
        library: Path | str | None = None,
        clock: Callable[[], str] = utc_now,
    ) -> None:
        if photo is not None and (
            not Path(photo).is_file() or Path(photo).suffix.lower() not in PHOTO_SUFFIXES
        ):
            raise InputError(f"--photo {photo}: not a PNG or JPEG file")
        self.editor = WorldEditor(
            world,
            surface_rules=surface_rules,
            replacement_rules=replacement_rules,
            library=library,
            clock=clock,
        )
        self.root = self.editor.root
        self.folder = self.root.parent.resolve()
        self.libraries = (
            self.editor.assets_dir,
            *asset_library.library_dirs(Path(library) if library else None),
        )
        self._lock = threading.Lock()
        self._glb: tuple[str, bytes] | None = None
        self._redo: list[HistoryEntry] = []
        self._redo_stamp = ""
        scene = read_values(self.editor.stage.GetPrimAtPath(WORLD_PATH)) if self._world_prim() else {}
        self.scene_values = scene
        self.photo = (
            Path(photo).resolve()
            if photo is not None
            else find_photo(self.folder, str(scene.get("usdworld:sourceImage", "")))
        )
        self.view_photos = self._view_photos()

    def _view_photos(self) -> dict[str, Path | None]:
        """Each view of a multi-view world (``/World/Cameras/<name>``) and its photo; {} for one view."""
        from usdworld.authoring.rig import CAMERAS_PATH

        world = self.editor.stage.GetPrimAtPath(WORLD_PATH)
        names = world.GetAttribute("usdworld:views").Get() if world else None
        images = world.GetAttribute("usdworld:viewImages").Get() if world else None
        if not names:
            return {}
        images = list(images) if images is not None and len(images) == len(names) else [""] * len(names)
        stage = self.editor.stage
        return {
            str(n): find_view_photo(self.folder, str(i))
            for n, i in zip(names, images)
            if stage.GetPrimAtPath(f"{CAMERAS_PATH}/{n}")
        }

    def view_photo(self, name: str) -> Path | None:
        """The photo of the view ``name`` of a multi-view world; None when it has none or no such view."""
        return self.view_photos.get(name)

    def _world_prim(self) -> bool:
        prim = self.editor.stage.GetPrimAtPath(WORLD_PATH)
        return bool(prim)

    def close(self) -> None:
        """Release the editor."""
        with self._lock:
            self.editor.close()

    # --- version -----------------------------------------------------------------------

    def version(self) -> str:
        """A short token that changes whenever a layer of the world is saved (see the module doc)."""
        parts = []
        for path in (self.root, self.editor.edits_path, *self.editor.base_paths):
            try:
                st = path.stat()
                parts.append(f"{st.st_ino}:{st.st_mtime_ns}:{st.st_size}")
            except OSError:
                parts.append("missing")
        return hashlib.sha256("|".join(parts).encode()).hexdigest()[:16]

    def _edits_digest(self) -> str:
        try:
            return hashlib.sha256(self.editor.edits_path.read_bytes()).hexdigest()
        except OSError:
            return ""

    def _can_redo(self) -> bool:
        return bool(self._redo) and self._redo_stamp == self._edits_digest()

    # --- reading -------------------------------------------------------------------------

    def camera_json(self, path: str = CAMERA_PATH) -> dict[str, Any] | None:
        """A camera (default the source camera) as three.js matrices, or None when the world has none.

        ``projection`` is :func:`usdworld.render.camera.gl_projection` of the camera's exact
        intrinsics (principal point and half-pixel convention included), ``world_from_glcam``
        the camera pose with GL axes (x right, y up, looking down -z), both column-major.
        The image size is the world's (every view of a rig has its photo's size).
        """
        from usdworld.render.camera import GL_FROM_CV, camera_from_usd, gl_projection

        prim = self.editor.stage.GetPrimAtPath(path)
        if not prim or not prim.IsActive():
            return None
        size = self.scene_values.get("usdworld:imageSize")
        if size is not None and int(size[0]) > 0 and int(size[1]) > 0:
            width, height = int(size[0]), int(size[1])
        else:
            h_ap = float(prim.GetAttribute("horizontalAperture").Get() or 1.0)
            v_ap = float(prim.GetAttribute("verticalAperture").Get() or 1.0)
            width, height = FALLBACK_WIDTH_PX, max(1, round(FALLBACK_WIDTH_PX * v_ap / h_ap))
        pose = camera_from_usd(prim, width, height)
        world_from_glcam = pose.world_from_cam @ GL_FROM_CV
        return {
            "width": width,
            "height": height,
            "K": jsonable(pose.K),
            "near_m": NEAR_M,
            "far_m": FAR_M,
            "vertical_fov_deg": math.degrees(2.0 * math.atan2(height / 2.0, pose.K[1, 1])),
            "projection": _column_major(gl_projection(pose.K, width, height, NEAR_M, FAR_M)),
            "world_from_glcam": _column_major(world_from_glcam),
        }

    def _classes_json(self, states: list[ObjectState]) -> dict[str, Any]:
        """Per class: its variants, and what each class may be replaced by (with variants)."""
        library = asset_library.available_classes(self.libraries)
        variants: dict[str, list[str]] = {}
        defaults: dict[str, str] = {}
        for name in sorted(set(library) | {s.class_name for s in states}):
            try:
                info = asset_library.asset_info(name, self.libraries)
            except InputError:
                continue
            variants[name], defaults[name] = list(info.variants), info.default_variant
        replace = {
            name: {
                alt: variants[alt]
                for alt in self.editor.replacement_rules.alternatives(name)
                if alt in variants
            }
            for name in sorted({s.class_name for s in states})
        }
        return {
            "addable": [c for c in library if c in variants],
            "variants": variants,
            "default_variant": defaults,
            "replace_with": replace,
        }

    def _objects_json(self, states: list[ObjectState]) -> list[dict[str, Any]]:
        points = np.array([s.position_world[:2] for s in states], dtype=np.float64).reshape(-1, 2)
        surfaces, _ = surface_at(points, self.editor.ground())
        out = []
        for state, surface in zip(states, surfaces):
            prim = self.editor.stage.GetPrimAtPath(state.path)
            out.append(object_json(state, surface, read_values(prim)))
        return out

    def snapshot(self) -> dict[str, Any]:
        """Everything the page shows: version, camera, scene facts, objects, classes, history."""
        version = self.version()  # before reading: a racing save shows up at the next poll
        with self._lock:
            states = self.editor.objects()
            history = self.editor.history()
            if self._world_prim():  # a rebuild may have changed the camera or the scene facts
                self.scene_values = read_values(self.editor.stage.GetPrimAtPath(WORLD_PATH))
            return {
                "version": version,
                "world": {
                    "root": str(self.root),
                    "name": self.folder.name,
                    "edits_layer": self.editor.edits_path.relative_to(self.folder).as_posix()
                    if self.editor.edits_path.resolve().is_relative_to(self.folder)
                    else str(self.editor.edits_path),
                },
                "scene": {
                    key: jsonable(self.scene_values.get(f"usdworld:{attr}"))
                    for attr, key in SCENE_KEYS.items()
                },
                "camera": self.camera_json(),
                "photo": self.photo is not None,
                "views": self._views_json(),
                "objects": self._objects_json(states),
                "classes": self._classes_json(states),
                "history": [history_json(e) for e in history[-HISTORY_SHOWN:]],
                "history_length": len(history),
                "can_undo": bool(history),
                "can_redo": self._can_redo(),
            }

    def _views_json(self) -> list[dict[str, Any]]:
        """The views of a multi-view world, in order: name, camera (as :meth:`camera_json`), whether
        it has a photo; [] for a single-view world."""
        from usdworld.authoring.rig import CAMERAS_PATH

        return [
            {"name": name, "camera": self.camera_json(f"{CAMERAS_PATH}/{name}"), "photo": photo is not None}
            for name, photo in self.view_photos.items()
        ]

    def scene_glb(self) -> tuple[str, bytes]:
        """(version, GLB bytes) of the composed world; cached per version."""
        from usdworld.render.scene import RenderScene
        from usdworld.serve.scene_glb import scene_glb

        version = self.version()
        with self._lock:
            if self._glb is not None and self._glb[0] == version:
                return self._glb
            self.editor.objects()  # brings the stage in line with the files
            glb = scene_glb(RenderScene.from_stage(self.editor.stage))
            self._glb = (version, glb)
            return self._glb

    def resolve_file(self, relative: str) -> Path:
        """A file inside the world folder, by its path relative to the folder.

        Raises:
            FileNotFoundError: no such file, a hidden name, a type not in
                :data:`SERVED_SUFFIXES` (lock files, temporary files), or a path that leaves
                the world folder (``..``, absolute, or a link pointing outside).
        """
        parts = relative.split("/")
        if (
            not relative
            or "\\" in relative
            or "\x00" in relative
            or relative.startswith("/")
            or any(p in ("", ".", "..") or p.startswith(".") for p in parts)
        ):
            raise FileNotFoundError(relative)
        path = (self.folder / relative).resolve()
        if (
            not path.is_relative_to(self.folder)
            or not path.is_file()
            or path.suffix.lower() not in SERVED_SUFFIXES
        ):
            raise FileNotFoundError(relative)
        return path

    # --- editing -------------------------------------------------------------------------

    def _call(self, op: str, args: dict[str, Any], force: bool = False) -> EditResult:
        e = self.editor
        if op == "move":
            return e.move(args["name"], to=_pair(args.get("to")), by=_pair(args.get("by")), force=force)
        if op == "rotate":
            return e.rotate(args["name"], float(args["yaw_deg"]), force=force)
        if op == "delete":
            return e.delete(args["name"])
        if op == "add":
            x, y = args["at"]
            yaw = args.get("yaw_deg")
            return e.add(
                args["class"],
                (float(x), float(y)),
                variant=args.get("variant"),
                yaw_deg=None if yaw is None else float(yaw),
                force=force,
            )
        if op == "replace":
            return e.replace(args["name"], args["with"], variant=args.get("variant"), force=force)
        if op == "restyle":
            return e.restyle(args["name"], args["color"])
        if op == "reset":
            return e.reset(args["name"], force=force)
        raise InputError(f"redo: cannot replay a '{op}' edit; undo it again or redo it from the command line")

    def apply(self, request: EditRequest) -> dict[str, Any]:
        """Run one edit, undo or redo.

        Returns:
            ``{"ok": True, "op", "name", "step", "message", "steps": [...]}``.

        Raises:
            EditRefused: the engine refuses the edit (a rule, a bad name, class, variant or
                colour, nothing to undo); nothing written.
            InputError: nothing to redo.
        """
        args = dict(request.args)
        with self._lock:
            if request.op == "undo":
                undone = self.editor.undo(int(args.get("steps", 1)))
                self._redo.extend(undone)
                self._redo_stamp = self._edits_digest()
                lines = [f"undid step {e.step}: {e.op} {e.args.get('name', '')}".rstrip() for e in undone]
                return {
                    "ok": True,
                    "op": "undo",
                    "name": "",
                    "step": undone[-1].step - 1,
                    "message": "; ".join(lines),
                }
            if request.op == "redo":
                return self._redo_steps(int(args.get("steps", 1)))
            result = self._call(request.op, args)
            self._redo, self._redo_stamp = [], ""
            return _result_json(result)

    def _redo_steps(self, steps: int) -> dict[str, Any]:
        if not self._redo:
            raise InputError("redo: nothing to redo (only edits undone from this page can be redone)")
        if self._redo_stamp != self._edits_digest():
            self._redo = []
            raise InputError(
                "redo: the edits layer changed since the undo (edited elsewhere); nothing to redo"
            )
        if steps > len(self._redo):
            raise InputError(f"redo {steps}: only {len(self._redo)} undone edit(s) to redo")
        done: list[EditResult] = []
        for _ in range(steps):
            entry = self._redo[-1]
            done.append(self._call(entry.op, dict(entry.args), force=entry.forced))
            self._redo.pop()
            self._redo_stamp = self._edits_digest()
        lines = [f"redid {r.op} {r.name} [step {r.step}]" for r in done]
        return {
            "ok": True,
            "op": "redo",
            "name": done[-1].name,
            "step": done[-1].step,
            "message": "; ".join(lines),
        }


def _pair(value: Any) -> tuple[float, float] | None:
    if value is None:
        return None
    return float(value[0]), float(value[1])


def _result_json(result: EditResult) -> dict[str, Any]:
    return {
        "ok": True,
        "op": result.op,
        "name": result.name,
        "step": result.step,
        "message": f"{result.message} [step {result.step}]",
        "forced": result.forced,
        "violations": list(result.violations),
    }
