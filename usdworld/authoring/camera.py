"""The source camera as a ``UsdGeom.Camera`` that reproduces the photo's intrinsics exactly.

USD lens attributes are in tenths of a scene unit: with metersPerUnit = 1, a 36 mm
sensor is written as 0.36. The principal point becomes the aperture offsets (sign
``W/2 - cx`` horizontally; image v points down, USD y up). OpenCV puts pixel centres
at integer coordinates while a rendered image's pixel ``i`` spans ``[i, i + 1]``, so
the principal point is shifted by half a pixel (``cx + 0.5``) to make a render from
this camera line up with the photo pixel for pixel.
"""

from __future__ import annotations

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom

from usdworld.frames import USDCAM_FROM_CAM
from usdworld.geometry.camera import PinholeCamera

#: Width of the virtual sensor in millimetres (full-frame).
SENSOR_WIDTH_MM = 36.0
CLIPPING_RANGE_M = (0.1, 2000.0)


def lens_attributes(camera: PinholeCamera, meters_per_unit: float = 1.0) -> dict[str, float]:
    """USD lens values for a pinhole camera.

    Args:
        camera: the camera (fx, fy, cx, cy, width, height).
        meters_per_unit: the stage's metres per unit.

    Returns:
        focalLength, horizontalAperture, verticalAperture and both offsets, in
        tenths of a scene unit.
    """
    pix = (SENSOR_WIDTH_MM / (100.0 * meters_per_unit)) / camera.width
    ratio = camera.fx / camera.fy
    return {
        "focalLength": camera.fx * pix,
        "horizontalAperture": camera.width * pix,
        "verticalAperture": camera.height * pix * ratio,
        "horizontalApertureOffset": (camera.width / 2.0 - (camera.cx + 0.5)) * pix,
        "verticalApertureOffset": ((camera.cy + 0.5) - camera.height / 2.0) * pix * ratio,
    }


def world_from_usdcam(camera: PinholeCamera) -> np.ndarray:
    """(4, 4) float64 transform of the USD camera prim (column-vector convention)."""
    T = camera.world_from_cam().copy()
    T[:3, :3] = T[:3, :3] @ USDCAM_FROM_CAM.T
    return T


def define_camera(stage: Usd.Stage, path: str, camera: PinholeCamera) -> UsdGeom.Camera:
    """Author a complete camera prim that looks through the source photo.

    Args:
        stage: stage whose edit target receives the prim.
        path: prim path, e.g. ``/World/SourceCamera``.
        camera: the source camera.

    Returns:
        The camera schema object.
    """
    mpu = UsdGeom.GetStageMetersPerUnit(stage)
    cam = UsdGeom.Camera.Define(stage, Sdf.Path(path))
    for name, value in lens_attributes(camera, mpu).items():
        cam.GetPrim().GetAttribute(name).Set(float(value))
    cam.CreateProjectionAttr(UsdGeom.Tokens.perspective)
    cam.CreateClippingRangeAttr(Gf.Vec2f(*CLIPPING_RANGE_M))
    matrix = Gf.Matrix4d(*world_from_usdcam(camera).T.ravel().tolist())
    cam.AddTransformOp().Set(matrix)
    return cam
