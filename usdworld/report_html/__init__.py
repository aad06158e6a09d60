"""``usdworld report``: one self-contained HTML page to check a built world.

Public API:

* :func:`write_report_page` ``(world, output, ...) -> Path``: gather, render and write the page.
* :func:`collect` -> :class:`PageInputs`; :func:`render_page` ``(inputs) -> str``.
* :func:`depth_cue_plot`, :func:`plan_view`: the page's inline SVG plots.

Not to be confused with :mod:`usdworld.report`, which makes the ``report.json`` a build writes;
this package reads that file.
"""

from __future__ import annotations

from pathlib import Path

from usdworld.report_html.collect import PageImages, PageInputs, collect
from usdworld.report_html.page import render_page
from usdworld.report_html.svg import depth_cue_plot, plan_view


def write_report_page(
    world: str | Path,
    output: str | Path,
    labels: Path | None = None,
    gt: Path | None = None,
    calib: Path | None = None,
    photo: Path | None = None,
    nuscenes_camera: str = "CAM_FRONT",
) -> Path:
    """Write the report page of a world (atomically) and return its path.

    Args:
        world: the world's ``world.usda`` or its folder.
        output: the HTML file to write.
        labels, gt, calib, photo, nuscenes_camera: as for :func:`collect`.

    Raises:
        InputError: not a world, no usable report.json, or unreadable labels, ground truth or photo.
        OutputError: ``output`` is a folder or cannot be written.
    """
    from usdworld.atomic import ensure_output_dir, write_text_atomic
    from usdworld.errors import OutputError

    out = Path(output)
    if out.is_dir():
        raise OutputError(f"{out}: is a folder; pass the HTML file to write, e.g. -o report.html")
    inputs = collect(world, labels=labels, gt=gt, calib=calib, photo=photo, nuscenes_camera=nuscenes_camera)
    ensure_output_dir(out.parent)
    write_text_atomic(out, render_page(inputs))
    return out


__all__ = [
    "PageImages",
    "PageInputs",
    "collect",
    "depth_cue_plot",
    "plan_view",
    "render_page",
    "write_report_page",
]
