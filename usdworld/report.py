"""``report.json``: the numbers of a built world in plain JSON, beside its USD provenance.

The report repeats what the world's layers record (camera, DLT, depth, every object's
cues and placement) and adds the inputs' digests and the parameters the build used, so a
world can be checked and compared without USD tools. Values are rounded to 6 decimals
(-0.0 written as 0.0); non-finite ones are null.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from usdworld.layout.model import WorldModel
from usdworld.parameters import Parameters


def _focal_entry(focal) -> dict | None:
    """How the focal length was estimated (every cue, used or dropped, and the pitch and roll the
    vanishing points imply, reported but not used by the camera fit), or None when K was given."""
    if focal is None:
        return None

    def cue(c) -> dict:
        return {"source": c.source, "f_px": _num(c.f_px), "sigma_log": _num(c.sigma_log), "detail": c.detail}

    return {
        "f_px": _num(focal.f_px),
        "sigma_log": _num(focal.sigma_log),
        "used": [cue(c) for c in focal.used],
        "dropped": [cue(c) for c in focal.dropped],
        "tilt": None
        if focal.tilt is None
        else {
            "pitch_deg": _num(float(np.degrees(focal.tilt[0]))),
            "roll_deg": _num(float(np.degrees(focal.tilt[1]))),
            "source": focal.tilt_source,
            "used": False,
        },
    }


def _lanes_entry(lanes) -> dict | None:
    """The lane-line pairs that measured the camera height (their spacing), or None when none did."""
    if lanes is None:
        return None
    return {
        "pairs": len(lanes),
        "k_per_row": [_num(k) for k in lanes.k],
        "sigma_log": [_num(s) for s in lanes.sigma_log],
        "implied_height_m": [_num(h) for h in lanes.heights_m()],
        "lane_width_m": _num(lanes.lane_width_m),
        "lane_width_sigma_log": _num(lanes.width_sigma_log),
    }


def _roll_entry(roll) -> dict | None:
    """How the roll was obtained (the vertical vanishing point fused with a level prior), or None
    when the camera file gave it."""
    if roll is None:
        return None
    m = roll.measurement
    return {
        "roll_deg": _num(np.degrees(roll.roll)),
        "sigma_deg": _num(np.degrees(roll.sigma)),
        "measured_deg": None if m is None else _num(np.degrees(m.roll)),
        "measured_sigma_deg": None if m is None else _num(np.degrees(m.sigma)),
        "source": "" if m is None else m.source,
        "used": roll.used,
    }


def _num(x: float | None) -> float | None:
    """A JSON number: rounded to 6 decimals, None when missing or not finite.

    A value that rounds to zero is written ``0.0`` whatever its sign: entries of the DLT
    homography that are zero in exact arithmetic come out as +-1e-18 noise, and the sign of
    that noise is not information.
    """
    if x is None:
        return None
    x = float(x)
    return round(x, 6) + 0.0 if np.isfinite(x) else None


def _light_entry(light) -> dict | None:
    """The sun and sky estimated from the photo, or None when not estimated."""
    if light is None:
        return None
    return {
        "method": light.method,
        "overcast": light.overcast,
        "sun_azimuth_deg": _num(np.degrees(light.sun_azimuth)),
        "sun_elevation_deg": _num(np.degrees(light.sun_elevation)),
        "shadow_contrast": _num(light.shadow_contrast),
        "shadow_share": _num(light.shadow_share),
        "fit_iou": _num(light.fit_iou),
        "casters": light.casters,
        "shadow_samples": light.shadow_samples,
        "fit_casters": light.fit_casters,
        "sky_zenith_linear": [_num(v) for v in light.sky_zenith_linear],
        "sky_horizon_linear": [_num(v) for v in light.sky_horizon_linear],
        "sky_source": light.sky_source,
    }


def make_report(model: WorldModel, params: Parameters) -> dict[str, Any]:
    """The ``report.json`` content: the same numbers as the USD provenance.

    Args:
        model: the built world.
        params: the parameters it was built with (recorded under ``parameters``).

    Returns:
        JSON-ready content (write it with ``sort_keys=True``).
    """
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
                "cut_sides": list(o.cut_sides),
                "bottom_occluded": o.bottom_occluded,
                "standing_on": o.standing_on,
                "position_world": [_num(c) for c in p.position_world],
                "yaw_deg": _num(np.degrees(p.yaw)),
                "yaw_source": p.yaw_source,
                "yaw_confidence": _num(p.yaw_confidence),
                "depth_m": _num(p.depth_m),
                "depth_method": p.depth_method,
                "depth_cues": {
                    c.name: {"depth_m": _num(c.depth_m), "sigma_m": _num(c.sigma_m), "note": c.note}
                    for c in p.cues
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
            "focal": _focal_entry(model.camera.focal),
            "lanes": _lanes_entry(model.camera.lanes),
            "roll": _roll_entry(model.camera.roll),
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
        "light": _light_entry(model.light),
        "objects": objects,
        "parameters": params.to_dict(),
        "warnings": list(model.warnings),
    }
