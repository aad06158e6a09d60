"""Per-object colour error between the photo and the render from the source camera.

For each placed object that has an image box (``usdworld:imageBBox``, source-image pixels),
the pixels compared are those of the **central half** of its box (the box shrunk by a
quarter of its width and height on each side, scaled to the render size) where the render
shows the object itself (its visible pixels). The photo's and the render's colours are the
per-channel medians of those pixels, sRGB decoded to linear RGB, then CIELAB (D65); the
error is their CIE76 and CIEDE2000 difference. Objects with fewer than
:data:`MIN_PIXELS` such pixels are left out.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from pxr import Usd

from usdworld.evaluation.colour_difference import delta_e76, delta_e2000
from usdworld.perception.colour_space import linear_to_lab, uint8_to_linear
from usdworld.render.scene import RenderScene

#: Fewest visible pixels an object's colour error is computed over.
MIN_PIXELS = 10
_BOX_ATTR = "usdworld:imageBBox"


@dataclass(frozen=True)
class ColourError:
    """One object's colour in the photo and in the render.

    Attributes:
        name: the object's prim name.
        class_name: its class label.
        pixels: pixels compared.
        photo_lab: (3,) float64 CIELAB of the photo's median colour.
        render_lab: (3,) float64 CIELAB of the render's median colour.
        delta_e76: CIE76 difference.
        delta_e2000: CIEDE2000 difference.
    """

    name: str
    class_name: str
    pixels: int
    photo_lab: np.ndarray
    render_lab: np.ndarray
    delta_e76: float
    delta_e2000: float

    def to_json(self) -> dict[str, Any]:
        """JSON-ready row (Lab rounded to 0.01)."""
        return {
            "name": self.name,
            "class": self.class_name,
            "pixels": self.pixels,
            "photo_lab": [round(float(v), 2) for v in self.photo_lab],
            "render_lab": [round(float(v), 2) for v in self.render_lab],
            "delta_e76": round(self.delta_e76, 3),
            "delta_e2000": round(self.delta_e2000, 3),
        }


def object_colour_errors(
    stage: Usd.Stage,
    scene: RenderScene,
    object_ids: np.ndarray,
    photo: np.ndarray,
    render: np.ndarray,
    source_size: tuple[int, int],
) -> list[ColourError]:
    """Colour error of every object visible in the render (module docstring).

    Args:
        stage: the composed world (object boxes are read from it).
        scene: the render scene (``object_ids`` index its ``objects``, 1-based).
        object_ids: (H, W) int32 rendered object index per pixel (0: none).
        photo: (H, W, 3) uint8 sRGB photo at the render's size.
        render: (H, W, 3) uint8 rendered colour.
        source_size: (width, height) of the source image the boxes are in.

    Returns:
        One row per object with at least :data:`MIN_PIXELS` compared pixels, in stage order.
    """
    h, w = object_ids.shape
    sx, sy = w / source_size[0], h / source_size[1]
    rows = []
    for obj in scene.objects:
        attr = stage.GetPrimAtPath(obj.path).GetAttribute(_BOX_ATTR)
        box = attr.Get() if attr and attr.HasAuthoredValue() else None
        if box is None:
            continue
        x0, y0, x1, y1 = float(box[0]) * sx, float(box[1]) * sy, float(box[2]) * sx, float(box[3]) * sy
        qx, qy = (x1 - x0) / 4.0, (y1 - y0) / 4.0
        c0, r0 = max(round(x0 + qx), 0), max(round(y0 + qy), 0)
        c1, r1 = min(round(x1 - qx), w), min(round(y1 - qy), h)
        if c1 <= c0 or r1 <= r0:
            continue
        visible = object_ids[r0:r1, c0:c1] == obj.index
        n = int(np.count_nonzero(visible))
        if n < MIN_PIXELS:
            continue
        photo_lab = linear_to_lab(np.median(uint8_to_linear(photo[r0:r1, c0:c1][visible]), axis=0))
        render_lab = linear_to_lab(np.median(uint8_to_linear(render[r0:r1, c0:c1][visible]), axis=0))
        rows.append(
            ColourError(
                name=obj.path.rsplit("/", 1)[-1],
                class_name=obj.class_name,
                pixels=n,
                photo_lab=photo_lab,
                render_lab=render_lab,
                delta_e76=float(delta_e76(photo_lab, render_lab)),
                delta_e2000=float(delta_e2000(photo_lab, render_lab)),
            )
        )
    return rows


def summarise_colour(rows: list[ColourError]) -> dict[str, Any]:
    """Medians over the objects, overall and per class (NaN-free: classes without rows are absent)."""

    def medians(sel: list[ColourError]) -> dict[str, Any]:
        return {
            "objects": len(sel),
            "median_delta_e76": float(np.median([r.delta_e76 for r in sel])) if sel else None,
            "median_delta_e2000": float(np.median([r.delta_e2000 for r in sel])) if sel else None,
        }

    out = medians(rows)
    out["per_class"] = {
        c: medians([r for r in rows if r.class_name == c]) for c in sorted({r.class_name for r in rows})
    }
    return out
