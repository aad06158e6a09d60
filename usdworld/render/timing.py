"""The time a drive's world is rendered at: ``render --time`` and ``flythrough --follow-ego``.

A drive's world (``build --views`` of timestamped views) has time codes: time code 0 is its
first frame, ``timeCodesPerSecond`` of them per second, ``endTimeCode`` its last frame. Its
moving objects have time-sampled transforms and visibility, and ``/World/Ego`` a
time-sampled trajectory. Both commands read the scene through :func:`scene_at`, so a video
frame of ``--follow-ego`` at a time code is the same scene ``render --time`` draws there.
"""

from __future__ import annotations

import math

from pxr import Usd

from usdworld.errors import InputError
from usdworld.render.instancing import Prototype, ViewCull
from usdworld.render.scene import RenderScene, StaticCache


def parse_time(stage: Usd.Stage, text: str) -> float:
    """The time code ``--time TEXT`` names: a time code (``3``, ``2.5``) or seconds (``1.25s``).

    Seconds count from time code 0 (the drive's first frame): code = seconds x ``timeCodesPerSecond``.

    Args:
        stage: the composed world.
        text: ``--time`` as given.

    Returns:
        The time code, within the stage's ``[startTimeCode, endTimeCode]``.

    Raises:
        InputError: not a number, the world has no time range, or the time lies outside it.

    Example:
        >>> from pxr import Sdf
        >>> layer = Sdf.Layer.CreateAnonymous(".usda")
        >>> layer.timeCodesPerSecond, layer.startTimeCode, layer.endTimeCode = 2.0, 0.0, 4.0
        >>> stage = Usd.Stage.Open(layer)
        >>> parse_time(stage, "3"), parse_time(stage, "1.25s")
        (3.0, 2.5)
    """
    raw = text.strip()
    seconds = raw.lower().endswith("s")
    try:
        value = float(raw[:-1] if seconds else raw)
    except ValueError:
        raise InputError(f"--time {text!r}: expected a time code (e.g. 3) or seconds (e.g. 1.5s)") from None
    if not math.isfinite(value):
        raise InputError(f"--time {text!r}: expected a finite time code or seconds")
    if not stage.HasAuthoredTimeCodeRange():
        raise InputError(
            f"--time {text}: the world has no time range (only a drive's world, build --views of "
            "timestamped views, has one); drop --time"
        )
    tcps = float(stage.GetTimeCodesPerSecond())
    code = value * tcps if seconds else value
    start, end = float(stage.GetStartTimeCode()), float(stage.GetEndTimeCode())
    if not start - 1e-9 <= code <= end + 1e-9:
        raise InputError(
            f"--time {text}: outside the world's time range, time codes {start:g} to {end:g} "
            f"({start / tcps:g} s to {end / tcps:g} s)"
        )
    return min(max(code, start), end)


def scene_at(
    stage: Usd.Stage,
    code: float | None,
    cull: ViewCull | None = None,
    prototypes: dict[tuple, Prototype | None] | None = None,
    static: StaticCache | None = None,
) -> RenderScene:
    """The scene at a time code: movers at their time-sampled places, hidden where they are not seen.

    Args:
        stage: the composed world.
        code: the time code, or None for the default time (every object at its default place).
        cull: as :meth:`RenderScene.from_stage`.
        prototypes: a cache of the assets' meshes shared by the calls on one unchanged stage.
        static: the objects that stand still, shared by the calls on one unchanged stage
            (:class:`~usdworld.render.scene.StaticCache`): each is read once.
    """
    time = None if code is None else Usd.TimeCode(float(code))
    return RenderScene.from_stage(stage, cull=cull, time=time, prototypes=prototypes, static=static)
