"""Terminal summary of a built world (rich table)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # rich takes ~40 ms to import: only when a summary is printed (not under -q)
    from rich.console import Console


def print_build_summary(report: dict[str, Any], world: str, console: Console | None = None) -> None:
    """Print one line per object (sorted by class, then name) and the camera/DLT facts.

    Args:
        report: the build report (``report.json`` content).
        world: path of the written root layer.
        console: where to print (stdout by default).
    """
    from rich.console import Console
    from rich.table import Table

    if console is None:
        console = Console()
        if not console.is_terminal:
            console = Console(width=160)
    table = Table(title=f"{len(report['objects'])} objects placed from {report['source_image']}")
    for column in ("name", "variant", "x m", "y m", "depth m", "method", "scale", "yaw deg", "moved m"):
        table.add_column(column, justify="right" if column.endswith(("m", "scale", "deg")) else "left")
    for o in sorted(report["objects"], key=lambda o: (o["class"], o["name"])):
        moved = sum(d * d for d in o["collision_displacement_m"]) ** 0.5
        table.add_row(
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
    console.print(table)
    cam = report["camera"]
    console.print(
        f"camera: height {cam['height_m']:.2f} m, pitch {cam['pitch_deg']:.2f} deg, fx {cam['K'][0][0]:.1f} px"
        + (f" (estimated: {', '.join(cam['estimated'])})" if cam["estimated"] else " (given)")
    )
    console.print(f"ground homography: DLT from {report['dlt']['source']}, RMS {report['dlt']['rms_px']:.3g} px")
    console.print(f"wrote {world}")
