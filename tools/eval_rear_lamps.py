"""Measure whether red rear lamps in a vehicle's box tell its back from its front (issue #22 item 5).

Every road vehicle's rear position lamps, stop lamps and rear reflex reflectors are red
(UN ECE Regulations 7, 3 and 48; FMVSS 108 with SAE J578 in the US); its front lamps are
white or amber. A vehicle seen from behind should therefore show a red patch on each side
of its rear, in the band where the regulations mount those lamps, and one seen from the
front none. This tool measures that cue on labelled photos (KITTI-format folders: ``image_2``
and ``label_2``) and reports how well it separates the vehicles facing away from the camera
from those facing it. It does not change ``build``: the cue was to be wired in only if it
separated on all the data together, and on KITTI's 25 dev frames and the nuScenes front frame
it does not (BENCHMARKS.md, "Rear lamps", session 9): lamps are seen on 18 of 38 vehicles facing
away and 3 of 31 facing the camera (AUC 0.70); among the resolved ones (step 6) on 9 of 25 and
0 of 18; and on none of the nuScenes frame's backs, whose lamps show no red in its photo.

The cue, per vehicle box (the pixels of the label's 2D box):

1. the body's colour: the trimmed median (:func:`usdworld.perception.appearance.trimmed_colour`)
   of the box's body band (``PerceptionParams.colour_body_rows``, a car's below its windows)
   inside the usual inner margin, so that a red car's own paint is the reference;
2. the lamp band: 0.35 m to 1.5 m above the box's bottom (:data:`LAMP_BAND_M`, the mounting
   heights of rear position and stop lamps in UN ECE R48), converted with the box height
   over the class's height (the vehicle seen end-on);
3. red pixels: CIELAB hue within :data:`RED_HUE_DEG` and a* at least :data:`MIN_RED_CONTRAST`
   above the body's;
4. in each half of the box, the largest 8-connected blob of red pixels in the band, as an
   area in square metres (pixels over (px per metre)^2);
5. the paired area is the smaller of the two halves' (both lamps must show): at least
   :data:`MIN_LAMP_AREA_M2` (a stop lamp's smallest lens, SAE J586 as incorporated in
   FMVSS 108) counts as "lamps seen";
6. the cue is "resolved" when that smallest lens covers :data:`MIN_LAMP_PIXELS` pixels or
   more at the box's scale; farther away a red pixel or two is as likely a colour fringe.

The truth: a label's heading ``(cos ry, -sin ry)`` in the camera's x-z plane against the
ray to its centre; ``cos`` of the angle between them at least :data:`END_ON_COS` is
"away" (its back in view), at most ``-END_ON_COS`` "towards", the rest "side".

Usage::

    python tools/eval_rear_lamps.py [DATA_DIR ...] [--verbose]

``DATA_DIR`` defaults to ``$USDWORLD_DATA/kitti/training`` and ``$USDWORLD_DATA/nuscenes/kitti_format``
(those that exist).
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.ndimage import label as connected_components

from usdworld.errors import InputError, UsdWorldError
from usdworld.io.class_table import load_class_table
from usdworld.io.detector_labels import detector_labels
from usdworld.io.images import read_image
from usdworld.parameters.perception import DEFAULT_PERCEPTION, PerceptionParams
from usdworld.perception.appearance import trimmed_colour
from usdworld.perception.colour_space import linear_to_lab, uint8_to_linear
from usdworld.resources import evaluation_data_dir

#: Label types counted as vehicles (tools/eval_kitti.py's VEHICLES).
VEHICLES = frozenset({"Car", "Van", "Truck", "Tram", "Bus", "Trailer", "Construction_vehicle", "Motorcycle"})

#: Heights above the ground of rear position and stop lamps, metres: UN ECE R48, 6.7.4 and
#: 6.10.4 ("not less than 350 mm nor more than 1,500 mm").
LAMP_BAND_M = (0.35, 1.5)

#: Smallest effective projected luminous lens area of a stop lamp, square metres: 50 cm^2
#: (7.75 in^2) on vehicles under 2,032 mm wide, SAE J586 FEB84 as incorporated in FMVSS 108.
MIN_LAMP_AREA_M2 = 0.005

#: CIELAB hue range of a red lamp's pixels, degrees. Tuned: chosen on the photos measured here
#: (KITTI 25 dev frames and nuScenes front together) among (0, 45), (10, 45) and (-10, 50);
#: CIE red signal light (y <= 0.335) lies below about 53 degrees, amber above about 65.
RED_HUE_DEG = (10.0, 45.0)

#: How far a red lamp's a* lies above the body's, CIELAB units. Tuned: chosen on the same
#: photos among 10, 16 and 24.
MIN_RED_CONTRAST = 16.0

#: Fewest pixels a stop lamp's smallest lens (:data:`MIN_LAMP_AREA_M2`) must cover for the cue to
#: count: a one-pixel red blob cannot be told from the one-pixel colour fringes that line
#: high-contrast edges in KITTI's photos (seen in the crops), and farther vehicles' lamps are
#: no bigger. Sampling; chosen after looking at the crops (20 px/m and more: 50 cm^2 >= 2 px).
MIN_LAMP_PIXELS = 2.0

#: |cos| of the angle between a vehicle's heading and the ray to it from which it counts as
#: seen end-on (within 60 degrees of its back or front), geometry.
END_ON_COS = 0.5


@dataclass(frozen=True)
class LampCue:
    """The red-lamp evidence in one vehicle box.

    Attributes:
        left_m2: area of the largest red blob in the lamp band of the box's left half, m^2.
        right_m2: the same in the right half, m^2.
        px_per_m: the scale used: box height over the class height, pixels per metre.
    """

    left_m2: float
    right_m2: float
    px_per_m: float

    @property
    def paired_m2(self) -> float:
        """The smaller half's area: both lamps of the pair must show."""
        return min(self.left_m2, self.right_m2)

    @property
    def resolved(self) -> bool:
        """A stop lamp's smallest lens covers at least :data:`MIN_LAMP_PIXELS` pixels at this scale."""
        return MIN_LAMP_AREA_M2 * self.px_per_m**2 >= MIN_LAMP_PIXELS

    @property
    def lamps_seen(self) -> bool:
        """Both halves hold a red blob at least a stop lamp's smallest lens (:data:`MIN_LAMP_AREA_M2`)."""
        return self.paired_m2 >= MIN_LAMP_AREA_M2


def lamp_cue(
    crop_rgb: np.ndarray,
    class_height_m: float,
    body_rows: tuple[float, float],
    params: PerceptionParams = DEFAULT_PERCEPTION,
) -> LampCue:
    """The red-lamp evidence in one vehicle's box (module docstring, steps 1 to 4).

    Args:
        crop_rgb: (H, W, 3) uint8 sRGB pixels of the box, H >= 2 and W >= 2.
        class_height_m: the vehicle class's height, metres (> 0).
        body_rows: the band of the box height (top, bottom fractions) holding the body colour.
        params: ``colour_*`` fields for the body colour.

    Returns:
        The two halves' largest red blob areas and the scale.

    Raises:
        InputError: a crop smaller than 2 x 2 pixels or a height not > 0.
    """
    rgb = np.asarray(crop_rgb)
    if rgb.ndim != 3 or rgb.shape[0] < 2 or rgb.shape[1] < 2 or rgb.shape[2] != 3:
        raise InputError(f"lamp_cue: the crop must be (H, W, 3) with H, W >= 2, got {rgb.shape}")
    if not class_height_m > 0:
        raise InputError(f"lamp_cue: class_height_m must be > 0, got {class_height_m}")
    h, w = rgb.shape[:2]
    linear = uint8_to_linear(rgb)
    margin = params.colour_inner_margin
    r0, r1 = int(h * max(body_rows[0], margin)), int(np.ceil(h * min(body_rows[1], 1.0 - margin)))
    c0, c1 = int(w * margin), int(np.ceil(w * (1.0 - margin)))
    body = linear[r0 : max(r1, r0 + 1), c0 : max(c1, c0 + 1)].reshape(-1, 3)
    body_a = float(linear_to_lab(trimmed_colour(body, "box", params).linear_rgb)[1])
    px_per_m = h / class_height_m
    top = int(np.clip(np.floor(h - LAMP_BAND_M[1] * px_per_m), 0, h - 1))
    bottom = int(np.clip(np.ceil(h - LAMP_BAND_M[0] * px_per_m), top + 1, h))
    lab = linear_to_lab(linear[top:bottom])
    hue = np.degrees(np.arctan2(lab[..., 2], lab[..., 1]))
    red = (hue >= RED_HUE_DEG[0]) & (hue <= RED_HUE_DEG[1]) & (lab[..., 1] - body_a >= MIN_RED_CONTRAST)
    half = w // 2
    area = 1.0 / px_per_m**2
    return LampCue(_largest_blob(red[:, :half]) * area, _largest_blob(red[:, w - half :]) * area, px_per_m)


def _largest_blob(mask: np.ndarray) -> int:
    """Pixels in the largest 8-connected blob of a (H, W) bool mask (0 when empty)."""
    labels, count = connected_components(mask, structure=np.ones((3, 3), dtype=bool))
    return int(np.bincount(labels.ravel())[1:].max()) if count else 0


def true_facing(ry: float, x_m: float, z_m: float) -> str:
    """``away``, ``towards`` or ``side`` from a KITTI label's rotation_y and centre (x, z) in metres."""
    ray = np.array([x_m, z_m]) / max(float(np.hypot(x_m, z_m)), 1e-9)
    c = float(np.cos(ry) * ray[0] - np.sin(ry) * ray[1])
    return "away" if c >= END_ON_COS else "towards" if c <= -END_ON_COS else "side"


def measure(data: Path, params: PerceptionParams = DEFAULT_PERCEPTION) -> list[dict]:
    """The cue and the truth for every vehicle label of a KITTI-format folder.

    Returns:
        One row per vehicle: frame, index among the non-DontCare labels, type, truth, cue.
    """
    frames = sorted((data / "image_2").glob("*.png"))
    if not frames:
        raise InputError(f"{data}/image_2 holds no PNG frames")
    labels, classes = detector_labels(), load_class_table()
    rows = []
    for image_path in frames:
        rgb = read_image(image_path).rgb
        text = (data / "label_2" / f"{image_path.stem}.txt").read_text()
        lines = [f for f in (ln.split() for ln in text.splitlines()) if f and f[0] != "DontCare"]
        for index, f in enumerate(lines):
            if f[0] not in VEHICLES:
                continue
            name = labels[f[0].lower()]
            x0, y0, x1, y1 = (int(round(float(v))) for v in f[4:8])
            x0, y0 = max(x0, 0), max(y0, 0)
            x1, y1 = min(x1, rgb.shape[1]), min(y1, rgb.shape[0])
            if x1 - x0 < 2 or y1 - y0 < 2:
                continue
            cue = lamp_cue(rgb[y0:y1, x0:x1], classes[name].size_m[2], params.colour_rows(name), params)
            facing = true_facing(float(f[14]), float(f[11]), float(f[13]))
            rows.append({"frame": image_path.stem, "index": index, "type": f[0], "truth": facing, "cue": cue})
    return rows


def auc(positives: list[float], negatives: list[float]) -> float:
    """Probability that a random positive scores above a random negative (ties count half)."""
    if not positives or not negatives:
        return float("nan")
    p, n = np.asarray(positives)[:, None], np.asarray(negatives)[None, :]
    return float(np.mean((p > n) + 0.5 * (p == n)))


def summary_lines(rows: list[dict]) -> list[str]:
    """The confusion tables (truth x lamps seen, all and resolved only) and the separation.

    Resolved: vehicles near enough that a stop lamp's smallest lens covers
    :data:`MIN_LAMP_PIXELS` pixels (:attr:`LampCue.resolved`); the others' cue is noise.
    """
    head = f"{'vehicles':>9}{'lamps seen':>12}{'none':>7}"
    out = [f"{'truth':<9}{head}{'resolved':>10}{head[9:]}"]
    for truth in ("away", "towards", "side"):
        group = [r["cue"] for r in rows if r["truth"] == truth]
        near = [c for c in group if c.resolved]
        seen, near_seen = sum(c.lamps_seen for c in group), sum(c.lamps_seen for c in near)
        out.append(
            f"{truth:<9}{len(group):>9}{seen:>12}{len(group) - seen:>7}"
            f"{len(near):>10}{near_seen:>12}{len(near) - near_seen:>7}"
        )
    away = [r["cue"] for r in rows if r["truth"] == "away"]
    towards = [r["cue"] for r in rows if r["truth"] == "towards"]
    out.append(
        "AUC of the paired area, away against towards: "
        f"{auc([c.paired_m2 for c in away], [c.paired_m2 for c in towards]):.3f}"
    )
    near_away, near_towards = [c for c in away if c.resolved], [c for c in towards if c.resolved]
    for what, a, t in (("all", away, towards), ("resolved", near_away, near_towards)):
        if a and t:
            out.append(f"likelihood ratio back:front ({what}), {_ratios(a, t)}")
    return out


def _ratios(away: list[LampCue], towards: list[LampCue]) -> str:
    """Lamps seen and none, each as P(cue | away) / P(cue | towards) with a half count added
    to every cell (Jeffreys: no zero count gives an infinite ratio)."""
    hit_a, hit_t = sum(c.lamps_seen for c in away), sum(c.lamps_seen for c in towards)
    n_a, n_t = len(away) + 1.0, len(towards) + 1.0
    seen = ((hit_a + 0.5) / n_a) / ((hit_t + 0.5) / n_t)
    none = ((len(away) - hit_a + 0.5) / n_a) / ((len(towards) - hit_t + 0.5) / n_t)
    return f"lamps seen {seen:.2f}, none {none:.2f}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", nargs="*", type=Path, help="KITTI-format folders (image_2, label_2)")
    parser.add_argument("--verbose", action="store_true", help="one line per vehicle")
    args = parser.parse_args(argv)
    shared = evaluation_data_dir()
    folders = args.data or [
        p for p in (shared / "kitti" / "training", shared / "nuscenes" / "kitti_format") if p.is_dir()
    ]
    if not folders:
        print(f"error: no data folder given and none under {evaluation_data_dir()}", file=sys.stderr)
        return 2
    try:
        rows = [row for folder in folders for row in measure(folder)]
    except UsdWorldError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.verbose:
        for r in rows:
            c = r["cue"]
            flag = ("lamps" if c.lamps_seen else "-") + ("" if c.resolved else " (unresolved)")
            print(
                f"{r['frame']:<10}{r['index']:>3} {r['type']:<6}{r['truth']:<8}"
                f" left {1e4 * c.left_m2:7.1f} cm2 right {1e4 * c.right_m2:7.1f} cm2"
                f" {c.px_per_m:6.1f} px/m {flag}"
            )
    for line in summary_lines(rows):
        print(line)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
