"""What each focal-length cue reads on real photos without their camera file, per frame.

For every frame of a KITTI-layout folder (``image_2``, ``label_2``, ``calib``: the KITTI
development frames, or nuScenes cameras written in that layout), and optionally a Cityscapes
frame (labels and instances, its true focal given), the photo is read as ``usdworld build``
reads it without a camera file (:func:`usdworld.pipeline.read_scene_head`), and every cue of
:func:`usdworld.layout.focal_cues.estimate_focal` is printed as its focal length over the
true one (``P2``'s ``fx``), with its spread: the prior, EXIF, the street's and the vertical
vanishing points, the lateral vanishing point, and the vehicles' box shapes (its profile's
mode, and how far the profile at the true focal length lies below it, in log-likelihood
units, also where the cue itself is left out), then the fused focal length. A summary line
gives the median signed and absolute error of the fusion over the frames.

Usage::

    PYTHONPATH=$PWD python tools/focal_report.py $USDWORLD_DATA/kitti/training
    PYTHONPATH=$PWD python tools/focal_report.py DIR --cityscapes $USDWORLD_DATA/cityscapes 282.9

It reads the data only; nothing is written.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from usdworld.authoring import asset_library
from usdworld.geometry.focal import box_shape_profile, exif_cue, prior_cue
from usdworld.geometry.lateral import lateral_focal_cue
from usdworld.geometry.vanishing import (
    detect_segments,
    find_vertical_vanishing_point,
    horizon_measurement,
    vanishing_focal_cue,
)
from usdworld.io.camera_files import read_kitti_projection
from usdworld.io.class_table import load_class_table
from usdworld.io.exif import read_exif_focal
from usdworld.layout.focal_cues import box_shapes, estimate_focal
from usdworld.parameters import Parameters
from usdworld.pipeline import BuildRequest, read_scene_head


def _pct(f: float, f_true: float) -> str:
    return f"{100 * (f / f_true - 1):+6.1f}%"


def frame_report(request: BuildRequest, f_true: float, params: Parameters) -> tuple[str, float]:
    """One line of the cues of one photo built without its camera file, and the fused focal length (px)."""
    table = load_class_table()
    head = read_scene_head(request, asset_library.library_dirs(None), table, params)
    image, cam = head.image, params.camera
    w, h = image.width, image.height
    segments = detect_segments(image.rgb, cam)
    street = head.vanishing
    vertical = find_vertical_vanishing_point(segments, w, h, cam)
    parts = [f"prior {_pct(prior_cue(w, h, cam).f_px, f_true)}"]
    exif = read_exif_focal(request.image, w, h)
    if exif is not None:
        parts.append(f"exif {_pct(exif_cue(exif.f_px, exif.detail, cam).f_px, f_true)}")
    vp = vanishing_focal_cue(street, vertical, w, h, cam)
    parts.append(f"vp {_pct(vp.f_px, f_true)}+-{100 * vp.sigma_log:.0f}%" if vp else "vp -")
    lateral = lateral_focal_cue(street, segments, w, h, cam)[0] if street is not None else None
    parts.append(f"lat {_pct(lateral.f_px, f_true)}+-{100 * lateral.sigma_log:.0f}%" if lateral else "lat -")
    shapes = box_shapes(head.objects, table, w, h, cam)
    vehicles = sum(
        1 for o in head.objects if table[o.class_name].yaw == "road" and table[o.class_name].kind == "thing"
    )
    text = f"shapes {len(shapes)}/{vehicles}"
    if len(shapes):
        horizon = horizon_measurement(street, prior_cue(w, h, cam).f_px, cam) if street is not None else None
        log_f, log_lik = box_shape_profile(w, h, shapes, street.u if street else None, horizon, cam)
        mode = float(np.exp(log_f[int(np.argmax(log_lik))]))
        at_true = float(np.interp(np.log(f_true), log_f, log_lik))
        at_prior = float(np.interp(np.log(prior_cue(w, h, cam).f_px), log_f, log_lik))
        text += f" mode {_pct(mode, f_true)} L(true) {at_true:+.2f} L(prior) {at_prior:+.2f}"
    parts.append(text)
    fused = estimate_focal(w, h, head.objects, table, street, segments, vertical, exif, cam)
    used = ",".join(c.source for c in fused.used if c.source != "prior") or "prior only"
    dropped = ",".join(c.source for c in fused.dropped)
    text = f"fused {_pct(fused.f_px, f_true)}+-{100 * fused.sigma_log:.0f}% [{used}]"
    parts.append(text + (f" dropped {dropped}" if dropped else ""))
    return " | ".join(parts), fused.f_px


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "data_dir", type=Path, nargs="?", help="KITTI-layout folder (image_2, label_2, calib)"
    )
    parser.add_argument(
        "--cityscapes",
        nargs=2,
        metavar=("DIR", "F_TRUE_PX"),
        help="also a Cityscapes folder (*_leftImg8bit.png with its labelIds and instanceIds) "
        "and its true focal length, px",
    )
    args = parser.parse_args(argv)
    params = Parameters()
    errors: list[float] = []
    with tempfile.TemporaryDirectory() as tmp:
        jobs: list[tuple[str, BuildRequest, float]] = []
        if args.data_dir is not None:
            for image in sorted((args.data_dir / "image_2").glob("*.png")):
                f_true = float(read_kitti_projection(args.data_dir / "calib" / f"{image.stem}.txt")[0, 0])
                req = BuildRequest(
                    image=image,
                    output=Path(tmp) / image.stem,
                    detections=args.data_dir / "label_2" / f"{image.stem}.txt",
                )
                jobs.append((image.stem, req, f_true))
        if args.cityscapes:
            folder, f_true = Path(args.cityscapes[0]), float(args.cityscapes[1])
            for image in sorted(folder.glob("*_leftImg8bit.png")):
                stem = image.name[: -len("_leftImg8bit.png")]
                req = BuildRequest(
                    image=image,
                    output=Path(tmp) / stem,
                    labels=folder / f"{stem}_gtFine_labelIds.png",
                    instances=folder / f"{stem}_gtFine_instanceIds.png",
                )
                jobs.append((stem, req, f_true))
        for name, req, f_true in jobs:
            line, f_fused = frame_report(req, f_true, params)
            errors.append(f_fused / f_true - 1)
            print(f"{name} {line}", flush=True)
    if not errors:
        print("error: no frames found", file=sys.stderr)
        return 2
    e = np.array(errors)
    print(
        f"fused focal error over {len(e)} frames: median signed {100 * np.median(e):+.1f} %, "
        f"median |error| {100 * np.median(np.abs(e)):.1f} %"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
