"""Does a ground truth belong to the world's scene? The checks behind ``usdworld evaluate --gt``.

Scoring a world against the ground truth of another frame gives numbers that look like a
(bad) result: nothing in the errors themselves says the files do not belong together. Three
things do, each checked where the ground truth carries it:

* **image size**: a synth ground truth records its camera's image size; the world records
  its source image's.
* **camera**: the synth camera's focal length and principal point against the world's
  ``SourceCamera`` at the same image size.
* **objects** (unless the world was built with the ground truth's own instance ids, which
  settles it): too few of the ground truth's vehicles and people overlap the placed object
  matched to them in the image. The matching gate is generous (2 m or a quarter of the
  distance), so street scenes match each other's buildings and trees by chance; vehicles
  and people do not. A pair overlaps when the two 3D boxes, seen through the world's camera,
  have 2D boxes of IoU >= 0.5 (the PASCAL VOC / KITTI 2D-detection criterion, as in
  ``tools/eval_kitti.py``). Without vehicles or people, all objects count.

Example::

    notes = scene_disagreements(gt, (2048, 1024), K, world_from_cam, matches, n_placed=48)
    # ('image size: the ground truth is of a 1024x512 image, the world of a 2048x1024 one', ...)
"""

from __future__ import annotations

import numpy as np

from usdworld.evaluation.ground_truth import GroundTruth
from usdworld.evaluation.objects import THING_CLASSES, ObjectMatch

#: Largest relative focal-length difference of one scene's cameras: a world built from a
#: camera file reproduces it exactly, and one whose focal length was estimated from the photo
#: is off by at most about 25 % (BENCHMARKS.md, KITTI frames without calibration).
FOCAL_TOLERANCE = 0.3
#: Largest principal-point distance, in image widths: a world without intrinsics puts it at
#: the image centre, and real cameras keep it within 3 % of the width of the centre (KITTI 1 %).
PRINCIPAL_POINT_TOLERANCE = 0.05
#: Two image boxes overlap at this IoU or more (PASCAL VOC / KITTI 2D detection).
OVERLAP_IOU = 0.5
#: Below this fraction of the ground truth's vehicles and people overlapping their match, the
#: ground truth is taken to be of another scene. Measured on synth scenes 7 and 8 at 1024x512:
#: a world against its own scene's truth 10 of 10; against another scene's 0 of 10, 0 of 15
#: and 2 of 15.
MIN_OVERLAP_FRACTION = 0.25
#: Box corners nearer than this to the camera plane (metres) are left out of the image box.
NEAR_M = 0.1


def image_box(
    bottom_centre_world: np.ndarray,
    heading_world: np.ndarray,
    size_lwh: np.ndarray,
    K: np.ndarray,
    world_from_cam: np.ndarray,
    image_size: tuple[int, int],
) -> np.ndarray | None:
    """The 2D box (clipped to the image) of an object's 3D box seen through a camera.

    Args:
        bottom_centre_world: (3,) float64 centre of the box's bottom face, metres.
        heading_world: (3,) float64 direction of the box's length axis.
        size_lwh: (3,) float64 length, width, height, metres.
        K: (3, 3) float64 intrinsics, pixels.
        world_from_cam: (4, 4) float64 camera pose (OpenCV camera frame).
        image_size: (width, height), pixels.

    Returns:
        (4,) float64 [u0, v0, u1, v1], or None when the box is behind the camera or outside the image.
    """
    h = np.array([heading_world[0], heading_world[1], 0.0])
    h = h / (np.linalg.norm(h) or 1.0)
    side = np.array([-h[1], h[0], 0.0])
    length, width, height = (float(v) for v in size_lwh)
    corners_world = np.array(
        [
            np.asarray(bottom_centre_world, dtype=np.float64)
            + a * length / 2 * h
            + b * width / 2 * side
            + c * np.array([0, 0, height])
            for a in (-1, 1)
            for b in (-1, 1)
            for c in (0, 1)
        ]
    )
    cam_from_world = np.linalg.inv(np.asarray(world_from_cam, dtype=np.float64))
    corners_cam = corners_world @ cam_from_world[:3, :3].T + cam_from_world[:3, 3]
    corners_cam = corners_cam[corners_cam[:, 2] > NEAR_M]
    if not len(corners_cam):
        return None
    px = corners_cam @ np.asarray(K, dtype=np.float64).T
    uv = px[:, :2] / px[:, 2:3]
    w, hh = image_size
    box = np.array(
        [max(uv[:, 0].min(), 0.0), max(uv[:, 1].min(), 0.0), min(uv[:, 0].max(), w), min(uv[:, 1].max(), hh)]
    )
    return box if box[2] > box[0] and box[3] > box[1] else None


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    iw = max(0.0, min(a[2], b[2]) - max(a[0], b[0]))
    ih = max(0.0, min(a[3], b[3]) - max(a[1], b[1]))
    inter = iw * ih
    union = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter
    return inter / union if union > 0 else 0.0


def overlapping(
    matches: list[ObjectMatch], K: np.ndarray, world_from_cam: np.ndarray, image_size: tuple[int, int]
) -> int:
    """How many matched pairs overlap in the image (2D boxes of IoU >= :data:`OVERLAP_IOU`)."""
    count = 0
    for m in matches:
        if m.placed is None:
            continue
        t, p = m.truth, m.placed
        a = image_box(t.bottom_centre_world, t.heading_world, t.obj.size_lwh, K, world_from_cam, image_size)
        b = image_box(p.bottom_centre_world, p.heading_world, p.size_lwh, K, world_from_cam, image_size)
        if a is not None and b is not None and _iou(a, b) >= OVERLAP_IOU:
            count += 1
    return count


def scene_disagreements(
    gt: GroundTruth,
    world_size: tuple[int, int],
    world_K: np.ndarray,
    world_from_cam: np.ndarray,
    matches: list[ObjectMatch],
    n_placed: int,
    ids_match: bool,
) -> tuple[str, ...]:
    """What says the ground truth is of another scene than the world (empty when nothing does).

    Args:
        gt: the ground truth.
        world_size: (width, height) of the world's source image, pixels.
        world_K: (3, 3) float64 intrinsics of the world's source camera at ``world_size``.
        world_from_cam: (4, 4) float64 pose of that camera.
        matches: the matching of the ground truth's objects (that count) to the placed ones.
        n_placed: objects the world places.
        ids_match: the world was built with the ground truth's instance ids (same scene).

    Returns:
        One readable line per disagreement.
    """
    notes: list[str] = []
    cam = gt.camera
    if cam is not None:
        if (cam.width, cam.height) != tuple(world_size):
            notes.append(
                f"image size: the ground truth is of a {cam.width}x{cam.height} image, "
                f"the world of a {world_size[0]}x{world_size[1]} one"
            )
        scale = world_size[0] / cam.width
        f_gt, f_world = float(cam.K[0, 0]) * scale, float(world_K[0, 0])
        pp_gt = np.asarray(cam.K[:2, 2], dtype=np.float64) * scale
        pp_off = float(np.hypot(*(pp_gt - world_K[:2, 2]))) / world_size[0]
        if abs(f_world / f_gt - 1.0) > FOCAL_TOLERANCE or pp_off > PRINCIPAL_POINT_TOLERANCE:
            notes.append(
                f"camera: the ground truth's focal length is {f_gt:.0f} px and principal point "
                f"({pp_gt[0]:.0f}, {pp_gt[1]:.0f}), the world's {f_world:.0f} px and "
                f"({world_K[0, 2]:.0f}, {world_K[1, 2]:.0f}) at {world_size[0]}x{world_size[1]}"
            )
    things = [m for m in matches if m.truth.obj.class_name in THING_CLASSES]
    counted, what = (things, "vehicles and people") if things else (matches, "objects")
    if not ids_match and counted:
        overlap = overlapping(counted, world_K, world_from_cam, world_size)
        if overlap < MIN_OVERLAP_FRACTION * len(counted):
            notes.append(
                f"objects: {overlap} of the ground truth's {len(counted)} {what} overlap the placed object "
                f"matched to them in the image (2D box IoU >= {OVERLAP_IOU}; the world places {n_placed} objects)"
            )
    return tuple(notes)
