"""The fixed choices of command-line options, as enums so that ``--help`` lists them.

Typer (pinned below 0.29) shows an enum option as ``[a|b|c]`` and refuses other values with
a usage error (exit 2); ``typing.Literal`` is not supported there. The values mirror the
domain's own tables (depth backends, export formats ...), imported lazily by the commands;
``tests/test_cli_choices.py`` checks that the two agree.
"""

from __future__ import annotations

import enum


class DepthBackendName(str, enum.Enum):
    """``--depth``: the depth backends of :func:`usdworld.perception.depth.make_backend`."""

    ground = "ground"
    monodepth = "monodepth"
    monodepth2 = "monodepth2"
    hf = "hf"
    file = "file"


class SegmentBackendName(str, enum.Enum):
    """``--segment``: the segmentation backends of :func:`usdworld.perception.segment.make_backend`."""

    none = "none"
    hf = "hf"


class Traffic(str, enum.Enum):
    """``--traffic``: the side traffic keeps to."""

    right = "right"
    left = "left"


class ExportFormat(str, enum.Enum):
    """``export --format``: the formats of :data:`usdworld.export.FORMATS`."""

    usdz = "usdz"
    usdc = "usdc"
    usda_flat = "usda-flat"
    glb = "glb"


class ViewsLayout(str, enum.Enum):
    """``build --layout``: what ``--views`` names (:data:`usdworld.views.build.LAYOUTS`)."""

    manifest = "manifest"
    nuscenes = "nuscenes"
