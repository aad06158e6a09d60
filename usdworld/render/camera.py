"""Cameras for the renderer: OpenCV ``K`` + ``world_from_cam`` <-> GL matrices and USD cameras.

GL pixel centres sit at ``i + 0.5`` while OpenCV's sit at integers, so the projection
uses ``cx + 0.5`` and ``cy + 0.5``: a world point then lands in the pixel whose index is
OpenCV's projection rounded, exactly (``../shared/notes/rendering.md``).

USD cameras are read with the inverse of :func:`usdworld.authoring.camera.lens_attributes`
(the formulas of ``../shared/notes/usd.md`` section 5 with the principal point in
continuous image coordinates, where pixel ``i`` spans ``[i, i + 1]``, as every USD
renderer uses them). Lens values cancel out, so their unit does not matter:

* ``fx = focalLength * W / horizontalAperture``, ``fy = focalLength * H / verticalAperture``
* ``cx = W/2 - W * horizontalApertureOffset / horizontalAperture - 0.5``
* ``cy = H/2 + H * verticalApertureOffset / verticalAperture - 0.5``

The aperture is stretched over the whole image (no conform policy), which is how
usdworld writes its cameras (``fx != fy`` is encoded in the aperture ratio).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pxr import Usd, UsdGeom

from usdworld.errors import CalibrationError
from usdworld.frames import USDCAM_FROM_CAM
from usdworld.render.scene import matrix_from_gf, world_from_stage

#: (4, 4) OpenCV camera axes -> GL eye axes (flip y and z).
GL_FROM_CV = np.diag([1.0, -1.0, -1.0, 1.0])


@dataclass(frozen=True)
class CameraPose:
    """Intrinsics and pose of a render camera.

    Attributes:
        K: (3, 3) float64 OpenCV camera matrix for an image of ``width`` x ``height``.
        world_from_cam: (4, 4) float64 rigid transform, OpenCV camera -> world (Z up, metres).
        width: image width in pixels.
        height: image height in pixels.
    """

    K: np.ndarray
    world_from_cam: np.ndarray
    width: int
    height: int


def check_intrinsics(K: np.ndarray) -> np.ndarray:
    """``K`` as a (3, 3) float64 array; raises CalibrationError when it is not a camera matrix."""
    K = np.asarray(K, dtype=np.float64)
    if K.shape != (3, 3) or not np.all(np.isfinite(K)) or K[0, 0] <= 0 or K[1, 1] <= 0:
        raise CalibrationError(
            f"render camera: K must be a finite 3x3 matrix with fx, fy > 0, got {K.tolist()}"
        )
    return K


def gl_projection(K: np.ndarray, width: int, height: int, near: float, far: float) -> np.ndarray:
    """(4, 4) float64 GL projection equivalent to ``K`` (skew included) with the half-pixel shift.

    Args:
        K: (3, 3) float64 OpenCV camera matrix.
        width: image width in pixels.
        height: image height in pixels.
        near: near clip distance, metres (> 0).
        far: far clip distance, metres (> near).
    """
    K = check_intrinsics(K)
    fx, s, cx, fy, cy = K[0, 0], K[0, 1], K[0, 2], K[1, 1], K[1, 2]
    P = np.zeros((4, 4))
    P[0, 0] = 2.0 * fx / width
    P[0, 1] = -2.0 * s / width  # GL y = -OpenCV y
    P[0, 2] = 1.0 - 2.0 * (cx + 0.5) / width
    P[1, 1] = 2.0 * fy / height
    P[1, 2] = 2.0 * (cy + 0.5) / height - 1.0
    P[2, 2] = -(far + near) / (far - near)
    P[2, 3] = -2.0 * far * near / (far - near)
    P[3, 2] = -1.0
    return P


def gl_view(world_from_cam: np.ndarray) -> np.ndarray:
    """(4, 4) float64 GL view matrix (world -> GL eye) for an OpenCV ``world_from_cam``."""
    return GL_FROM_CV @ np.linalg.inv(np.asarray(world_from_cam, dtype=np.float64))


def camera_from_usd(
    prim: Usd.Prim, width: int, height: int, time: Usd.TimeCode | None = None
) -> CameraPose:
    """Intrinsics and pose of a ``UsdGeom.Camera`` prim for a ``width`` x ``height`` image.

    Args:
        prim: a Camera prim of a composed stage.
        width: image width in pixels.
        height: image height in pixels.
        time: the time code of the pose (a camera on a time-sampled Xform); default the default time.

    Raises:
        CalibrationError: the prim is not a camera or its apertures / focal length are not > 0.
    """
    camera = UsdGeom.Camera(prim)
    if not camera:
        raise CalibrationError(f"{prim.GetPath()}: not a UsdGeom.Camera prim; pass a camera prim path")
    t = Usd.TimeCode.Default()
    focal = float(camera.GetFocalLengthAttr().Get(t))
    h_ap = float(camera.GetHorizontalApertureAttr().Get(t))
    v_ap = float(camera.GetVerticalApertureAttr().Get(t))
    h_off = float(camera.GetHorizontalApertureOffsetAttr().Get(t))
    v_off = float(camera.GetVerticalApertureOffsetAttr().Get(t))
    if not (focal > 0 and h_ap > 0 and v_ap > 0):
        raise CalibrationError(
            f"{prim.GetPath()}: focalLength {focal} and apertures {h_ap} x {v_ap} must be > 0; fix the camera"
        )
    K = np.array(
        [
            [focal * width / h_ap, 0.0, width / 2.0 - width * h_off / h_ap - 0.5],
            [0.0, focal * height / v_ap, height / 2.0 + height * v_off / v_ap - 0.5],
            [0.0, 0.0, 1.0],
        ]
    )
    world_from_usdcam = world_from_stage(prim.GetStage()) @ matrix_from_gf(
        UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(t if time is None else time)
    )
    usdcam_from_cam = np.eye(4)
    usdcam_from_cam[:3, :3] = USDCAM_FROM_CAM
    world_from_cam = world_from_usdcam @ usdcam_from_cam
    # Remove any scale in the camera's transform (rotation + translation only).
    R = world_from_cam[:3, :3]
    norms = np.linalg.norm(R, axis=0)
    world_from_cam[:3, :3] = R / norms
    return CameraPose(K=K, world_from_cam=world_from_cam, width=width, height=height)
