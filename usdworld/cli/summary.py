"""Terminal summary of a built world: a box-drawn table, one row per object, and the camera facts.

The table is drawn here, in plain text, rather than by rich: importing and laying out a rich
table took about a tenth of a second of every ``usdworld build``, as much as building the
world's objects. It looks as rich's default table does (heavy head, title centred above and
wrapped to the table's width; the same characters as rich prints to a file), without colours.
"""

from __future__ import annotations

import sys
from typing import Any, TextIO

#: Columns of the table; those ending in a unit (or ``scale``) are numbers, right-justified.
COLUMNS = ("name", "variant", "x m", "y m", "depth m", "method", "scale", "yaw deg", "moved m")


def _wrap(text: str, width: int) -> list[str]:
    """Greedy word wrap to ``width`` characters; a word longer than that is cut into pieces."""
    lines: list[str] = []
    line = ""
    for word in text.split():
        while len(word) > width:
            if line:
                lines.append(line)
                line = ""
            lines.append(word[:width])
            word = word[width:]
        if line and len(line) + 1 + len(word) > width:
            lines.append(line)
            line = word
        else:
            line = f"{line} {word}" if line else word
    if line or not lines:
        lines.append(line)
    return lines


def format_table(title: str, columns: tuple[str, ...], rows: list[tuple[str, ...]]) -> str:
    """A box-drawn table (rich's ``HEAVY_HEAD`` box, one space of padding) with a centred title.

    Args:
        title: the line above the table (wrapped to the table's width).
        columns: the header cells; a header ending in ``m``, ``scale`` or ``deg`` right-justifies its column.
        rows: the body cells, one tuple per row, as many cells as ``columns``.

    Returns:
        The lines of the table, each ending in a newline.
    """
    widths = [max([len(c)] + [len(r[i]) for r in rows]) for i, c in enumerate(columns)]
    right = [c.endswith(("m", "scale", "deg")) for c in columns]

    def line(cells: tuple[str, ...], edge: str) -> str:
        parts = (cell.rjust(w) if r else cell.ljust(w) for cell, w, r in zip(cells, widths, right))
        return edge + edge.join(f" {p} " for p in parts) + edge

    def rule(left: str, fill: str, middle: str, end: str) -> str:
        return left + middle.join(fill * (w + 2) for w in widths) + end

    total = sum(widths) + 3 * len(widths) + 1
    out = [
        *(" " * ((total - len(t)) // 2) + t + " " * (total - len(t) - (total - len(t)) // 2) for t in _wrap(title, total)),
        rule("┏", "━", "┳", "┓"),
        line(columns, "┃"),
        rule("┡", "━", "╇", "┩"),
        *(line(r, "│") for r in rows),
        rule("└", "─", "┴", "┘"),
    ]
    return "".join(f"{s}\n" for s in out)


def light_line(light: dict[str, Any]) -> str:
    """One line saying where the world's sun comes from and how sure it is.

    Args:
        light: the report's ``light`` entry (method, sun, fit IoU, casters).
    """
    sun = f"sun azimuth {light['sun_azimuth_deg']:.0f} deg, elevation {light['sun_elevation_deg']:.0f} deg"
    method = light["method"]
    if method == "cast_shadows":
        how = f"fitted to the shadows of {light.get('fit_casters', 0)} objects, overlap {light['fit_iou']:.2f}"
    elif method == "weak_fit":
        how = (
            f"the default: the shadow fit is too weak to trust (overlap {light['fit_iou']:.2f}, "
            f"{light.get('fit_casters', 0)} objects)"
        )
    elif method == "overcast":
        return "light: overcast (no cast shadows next to the objects)"
    else:
        how = "the default: no object with visible ground around it"
    return f"light: {sun} ({how})"


def print_build_summary(report: dict[str, Any], world: str, file: TextIO | None = None) -> None:
    """Print one line per object (sorted by class, then name) and the camera/DLT facts.

    Args:
        report: the build report (``report.json`` content).
        world: path of the written root layer.
        file: where to print (stdout by default).
    """
    rows = []
    for o in sorted(report["objects"], key=lambda o: (o["class"], o["name"])):
        moved = sum(d * d for d in o["collision_displacement_m"]) ** 0.5
        rows.append(
            (
                o["name"],
                o["variant"],
                f"{o['position_world'][0]:.2f}",
                f"{o['position_world'][1]:.2f}",
                f"{o['depth_m']:.2f}",
                o["depth_method"],
                f"{o['scale']:.2f}",
                f"{o['yaw_deg']:.0f}",
                f"{moved:.2f}" if moved else "",
            )
        )
    cam = report["camera"]
    text = format_table(f"{len(report['objects'])} objects placed from {report['source_image']}", COLUMNS, rows)
    text += (
        f"camera: height {cam['height_m']:.2f} m, pitch {cam['pitch_deg']:.2f} deg, fx {cam['K'][0][0]:.1f} px"
        + (f" (estimated: {', '.join(cam['estimated'])})" if cam["estimated"] else " (given)")
        + f"\nground homography: DLT from {report['dlt']['source']}, RMS {report['dlt']['rms_px']:.3g} px"
        + (f"\n{light_line(report['light'])}" if report.get("light") else "")
        + f"\nwrote {world}\n"
    )
    (file or sys.stdout).write(text)
