"""Named coordinate frames and the fixed conversions between them (leaf module).

Frames (suffixes used in every variable name):

* ``_px``: image pixels, origin at the top-left pixel's corner, u right, v down.
* ``_cam``: OpenCV camera, x right, y down, z forward (optical axis), metres.
* ``_usdcam``: USD/OpenGL camera, x right, y up, looking down -Z.
* ``_world``: right-handed, Z up, X forward, Y left, metres; the ground is z = 0
  and the origin is on the ground straight below the camera centre.
* ``_ground``: (x, y) on the ground plane z = 0 of the world frame.

Transforms are named ``dst_from_src`` and applied to column vectors:
``p_world = world_from_cam @ p_cam``.
"""

from __future__ import annotations

import numpy as np

#: Rotation taking OpenCV camera axes to world axes for a level camera looking
#: along world +X (zero pitch, roll and yaw): cam z -> world X, cam x -> -Y,
#: cam y -> -Z.
WORLD_FROM_CAM_LEVEL: np.ndarray = np.array(
    [[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]], dtype=np.float64
)
WORLD_FROM_CAM_LEVEL.setflags(write=False)

#: Rotation taking OpenCV camera axes to USD camera axes (flip y and z).
USDCAM_FROM_CAM: np.ndarray = np.diag([1.0, -1.0, -1.0])
USDCAM_FROM_CAM.setflags(write=False)


def rotation_world_from_vehicle(pitch: float, roll: float, yaw: float) -> np.ndarray:
    """ISO 8855 vehicle-style rotation ``Rz(yaw) @ Ry(pitch) @ Rx(roll)``.

    Positive pitch tilts the forward axis down (towards -Z), positive roll tilts
    the left axis up, positive yaw turns left. Same convention as Cityscapes'
    camera extrinsics.

    Args:
        pitch: radians.
        roll: radians.
        yaw: radians.

    Returns:
        (3, 3) float64 rotation matrix.
    """
    cp, sp = np.cos(pitch), np.sin(pitch)
    cr, sr = np.cos(roll), np.sin(roll)
    cy, sy = np.cos(yaw), np.sin(yaw)
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    return rz @ ry @ rx
