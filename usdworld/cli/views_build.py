"""``usdworld build --views``: several views of one rig to one world (called by :mod:`usdworld.cli.build_cmd`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from usdworld.errors import InputError

#: The single-image options that a views build takes from each view instead.
PER_VIEW_OPTIONS = (
    "image",
    "labels",
    "instances",
    "polygons",
    "detections",
    "camera",
    "ground_plane",
    "ground_points",
    "depth_map",
)


def check_options(views: Path | None, given: dict[str, Any], layout_given: bool) -> None:
    """Refuse options that do not fit a single-image or a views build, with a one-line message.

    Args:
        views: ``--views``, or None for a single-image build.
        given: the per-view options by name (None when not given).
        layout_given: whether ``--layout``, ``--sample`` or ``--jobs`` was given.

    Raises:
        InputError: a per-view option with ``--views``; a views option or no image without it.
    """
    if views is None:
        if layout_given:
            raise InputError("--layout, --sample and --jobs go with --views (several views, one world)")
        if given.get("image") is None:
            raise InputError(
                "pass the photo (usdworld build IMAGE -o OUT), or several views with --views VIEWS.json"
            )
        return
    for name in PER_VIEW_OPTIONS:
        if given.get(name) is not None:
            flag = "IMAGE" if name == "image" else f"--{name.replace('_', '-')}"
            raise InputError(f"{flag}: a views build takes each view's inputs from --views; drop {flag}")


def run(
    views: Path,
    layout: str,
    sample: str | None,
    jobs: int | None,
    output: Path,
    options: dict[str, Any],
) -> Any:
    """Read the view set and build its world.

    Args:
        views: the manifest or info file.
        layout: ``manifest`` or ``nuscenes``.
        sample: a nuScenes sample token, or None for the first.
        jobs: worker processes, or None for one per view up to the CPU count.
        output: the world folder.
        options: the shared options of :class:`usdworld.views.build.ViewsRequest`
            (depth, depth_weights, library, max_range_m, params, traffic).

    Returns:
        The :class:`usdworld.pipeline.BuildResult`.
    """
    from usdworld.views.build import ViewsRequest, build_views, read_view_set

    return build_views(ViewsRequest(read_view_set(views, layout, sample), output, jobs=jobs, **options))
