"""Inline SVG plots of a world's ``report.json`` objects (no plotting library).

* :func:`depth_cue_plot`: each object's depth cues, with one-sigma bars, against the fused depth.
* :func:`plan_view`: the objects' footprints seen from above, with the camera's field of view.

Both take the ``objects`` list of ``report.json`` (dictionaries as :func:`usdworld.report.make_report`
writes them) and return an ``<svg>`` element as text. Every mark carries a ``<title>``, which
browsers show as a tooltip.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from html import escape
from typing import Any

#: Colours of the depth cues, by cue name; cues not listed take :data:`OTHER_CUE_COLOURS` in turn.
CUE_COLOURS = {"contact": "#1f77b4", "height": "#ff7f0e", "cnn": "#2ca02c"}
OTHER_CUE_COLOURS = ("#9467bd", "#8c564b", "#e377c2", "#17becf")


def nice_step(span: float, ticks: int = 6) -> float:
    """A tick step of 1, 2 or 5 times a power of ten giving about ``ticks`` ticks over ``span``.

    >>> nice_step(47.0), nice_step(0.8), nice_step(120.0)
    (10.0, 0.2, 20.0)
    """
    if not span > 0 or not math.isfinite(span):
        return 1.0
    raw = span / ticks
    power = 10.0 ** math.floor(math.log10(raw))
    for m in (1.0, 2.0, 5.0, 10.0):
        if raw <= m * power * 1.0000001:
            return m * power
    return 10.0 * power  # pragma: no cover  (the loop always returns)


def _finite(x: Any) -> bool:
    return isinstance(x, (int, float)) and math.isfinite(x)


def cue_colours(objects: Sequence[Mapping[str, Any]]) -> dict[str, str]:
    """Colour of every cue name that gives at least one of the objects a depth, in sorted name order."""
    names = sorted(
        {
            name
            for o in objects
            for name, c in (o.get("depth_cues") or {}).items()
            if _finite(c.get("depth_m"))
        }
    )
    others = iter(OTHER_CUE_COLOURS * (1 + len(names)))
    return {n: CUE_COLOURS[n] if n in CUE_COLOURS else next(others) for n in names}


def log_ticks(lo: float, hi: float) -> list[float]:
    """The 1, 2, 5 x 10^k values in [lo, hi] (both > 0).

    >>> log_ticks(3.0, 60.0)
    [5.0, 10.0, 20.0, 50.0]
    """
    out = []
    for k in range(math.floor(math.log10(lo)), math.ceil(math.log10(hi)) + 1):
        out += [m * 10.0**k for m in (1.0, 2.0, 5.0) if lo <= m * 10.0**k <= hi]
    return out


def depth_cue_plot(objects: Sequence[Mapping[str, Any]], width: int = 900, row_px: int = 16) -> str:
    """Each object's depth cues (dots, one-sigma bars) and its fused depth (black tick), one row each.

    The depth axis is logarithmic (near and far objects both readable; a cue's sigma grows
    with its depth). Rows are in order of fused depth; cues without a value (a note says
    why) are left out. Bars that reach past the axis are cut at its ends.

    Args:
        objects: ``report.json`` objects (``name``, ``depth_m``, ``depth_cues``).
        width: width of the plot in pixels.
        row_px: height of one object's row in pixels.

    Returns:
        An ``<svg>`` element; a short ``<p>`` when no object has a depth.
    """
    rows = sorted((o for o in objects if _finite(o.get("depth_m"))), key=lambda o: (o["depth_m"], o["name"]))
    if not rows:
        return '<p class="note">No object has a fused depth to plot.</p>'
    colours = cue_colours(rows)
    values = [o["depth_m"] for o in rows] + [
        c["depth_m"] for o in rows for c in (o.get("depth_cues") or {}).values() if _finite(c.get("depth_m"))
    ]
    values = [v for v in values if v > 0] or [1.0]
    lo, hi = min(values) / 1.1, max(values) * 1.1
    x_min = max([t for t in log_ticks(lo / 10.0, lo)] or [lo])
    x_max = min([t for t in log_ticks(hi, hi * 10.0)] or [hi])
    log_span = math.log10(x_max / x_min)
    left, right, top, bottom = 130, 20, 28, 34
    plot_w = width - left - right
    height = top + bottom + row_px * len(rows)

    def x(d: float) -> float:
        return left + plot_w * math.log10(min(max(d, x_min), x_max) / x_min) / log_span

    out = [
        (
            f'<svg xmlns="http://www.w3.org/2000/svg" class="plot" id="depth-plot" width="{width}" height="{height}" '
            f'viewBox="0 0 {width} {height}" role="img" aria-label="depth cues against fused depth">'
        )
    ]
    for t in log_ticks(x_min, x_max):
        out.append(
            f'<line x1="{x(t):.1f}" y1="{top}" x2="{x(t):.1f}" y2="{height - bottom}" class="grid"/>'
            f'<text x="{x(t):.1f}" y="{height - bottom + 14}" text-anchor="middle">{t:g}</text>'
        )
    out.append(
        f'<text x="{left + plot_w / 2:.1f}" y="{height - 4}" text-anchor="middle">depth (m, log scale)</text>'
    )
    lx = left
    for name, colour in colours.items():
        out.append(
            f'<circle cx="{lx + 5}" cy="12" r="4" fill="{colour}"/><text x="{lx + 13}" y="16">{escape(name)} ± σ</text>'
        )
        lx += 13 + 7 * (len(name) + 4) + 16
    out.append(
        f'<line x1="{lx}" y1="5" x2="{lx}" y2="19" class="fused"/><text x="{lx + 6}" y="16">fused depth</text>'
    )
    offsets = {name: (i - (len(colours) - 1) / 2) * 3.0 for i, name in enumerate(colours)}
    for i, o in enumerate(rows):
        cy = top + row_px * (i + 0.5)
        name = escape(str(o["name"]))
        out.append(
            f'<g class="row" data-name="{name}"><text x="{left - 6}" y="{cy + 4:.1f}" text-anchor="end">{name}</text>'
        )
        for cue, c in sorted((o.get("depth_cues") or {}).items()):
            d, s = c.get("depth_m"), c.get("sigma_m")
            if not _finite(d):
                continue
            y = cy + offsets[cue]
            tip = (
                f"{o['name']} {cue}: {d:.2f} m"
                + (f" ± {s:.2f} m" if _finite(s) else "")
                + (f" ({c['note']})" if c.get("note") else "")
            )
            if _finite(s):
                out.append(
                    f'<line x1="{x(d - s):.1f}" y1="{y:.1f}" x2="{x(d + s):.1f}" y2="{y:.1f}" stroke="{colours[cue]}" class="bar"/>'
                )
            out.append(
                f'<circle class="cue" cx="{x(d):.1f}" cy="{y:.1f}" r="3.5" fill="{colours[cue]}"><title>{escape(tip)}</title></circle>'
            )
        fx = x(o["depth_m"])
        tip = f"{o['name']} fused: {o['depth_m']:.2f} m ({o.get('depth_method', '')})"
        out.append(
            f'<line class="fused" x1="{fx:.1f}" y1="{cy - row_px * 0.45:.1f}" x2="{fx:.1f}" y2="{cy + row_px * 0.45:.1f}">'
            f"<title>{escape(tip)}</title></line></g>"
        )
    out.append("</svg>")
    return "".join(out)


def _footprint(o: Mapping[str, Any]) -> list[tuple[float, float]] | None:
    """(4, 2) ground corners (x, y) of an object's footprint, metres, or None without numbers."""
    pos, size, yaw = o.get("position_world"), o.get("size_m"), o.get("yaw_deg")
    if not (pos and size and _finite(yaw) and all(_finite(v) for v in (*pos[:2], *size[:2]))):
        return None
    c, s = math.cos(math.radians(yaw)), math.sin(math.radians(yaw))
    half_l, half_w = size[0] / 2, size[1] / 2
    return [
        (pos[0] + c * dl - s * dw, pos[1] + s * dl + c * dw)
        for dl, dw in ((half_l, half_w), (half_l, -half_w), (-half_l, -half_w), (-half_l, half_w))
    ]


def plan_view(
    objects: Sequence[Mapping[str, Any]],
    colours: Mapping[str, str],
    half_fov_rad: tuple[float, float] | None = None,
    size_px: int = 560,
) -> str:
    """The objects' footprints from above: world X (forward) up, Y (left) to the left.

    Args:
        objects: ``report.json`` objects (``position_world``, ``size_m`` as length, width,
            height, ``yaw_deg``, ``class``).
        colours: CSS colour per class name (missing classes are grey).
        half_fov_rad: the camera's half field of view to the left and to the right
            (radians), drawn as a wedge from the origin; None for none.
        size_px: width and height of the plot in pixels.

    Returns:
        An ``<svg>`` element; a short ``<p>`` when no object can be drawn.
    """
    shapes = [(o, f) for o in objects if (f := _footprint(o)) is not None]
    if not shapes:
        return '<p class="note">No object has a position to draw.</p>'
    xs = [0.0] + [p[0] for _, f in shapes for p in f]
    ys = [0.0] + [p[1] for _, f in shapes for p in f]
    span = max(max(xs) - min(xs), max(ys) - min(ys), 1.0) * 1.08
    cx, cy = (max(xs) + min(xs)) / 2, (max(ys) + min(ys)) / 2
    scale = (size_px - 40) / span

    def pt(x: float, y: float) -> str:  # world (x forward, y left) -> svg (right, down)
        return f"{size_px / 2 - (y - cy) * scale:.1f},{size_px / 2 - (x - cx) * scale + 10:.1f}"

    out = [
        (
            f'<svg xmlns="http://www.w3.org/2000/svg" class="plot" id="plan-view" width="{size_px}" height="{size_px + 20}" '
            f'viewBox="0 0 {size_px} {size_px + 20}" role="img" aria-label="plan view of the objects">'
        )
    ]
    if half_fov_rad is not None:
        reach = span
        left, right = half_fov_rad
        a = pt(reach, reach * math.tan(left))
        b = pt(reach, -reach * math.tan(right))
        out.append(
            f'<polygon class="fov" points="{pt(0, 0)} {a} {b}"><title>camera field of view</title></polygon>'
        )
    for o, f in sorted(shapes, key=lambda s: -s[0]["position_world"][0]):
        tip = f"{o['name']} ({o.get('class', '')}): x {o['position_world'][0]:.1f} m, y {o['position_world'][1]:.1f} m, yaw {o['yaw_deg']:.0f}°"
        colour = colours.get(str(o.get("class")), "#888888")
        out.append(
            f'<polygon class="footprint" points="{" ".join(pt(*p) for p in f)}" fill="{colour}">'
            f"<title>{escape(tip)}</title></polygon>"
        )
    out.append(
        f'<circle cx="{pt(0, 0).split(",")[0]}" cy="{pt(0, 0).split(",")[1]}" r="4" class="camera"><title>camera</title></circle>'
    )
    bar = nice_step(span, 4)
    out.append(
        f'<line x1="10" y1="14" x2="{10 + bar * scale:.1f}" y2="14" class="scalebar"/>'
        f'<text x="{14 + bar * scale:.1f}" y="18">{bar:g} m</text>'
    )
    out.append("</svg>")
    return "".join(out)
