"""Tuned numbers of the fly-through video: its H.264 encoder (:mod:`usdworld.render.video`) and
the cheaper shading its frames are rendered with (:mod:`usdworld.render.flythrough`).

A section of its own, not a field of :class:`~usdworld.parameters.Parameters`, so that the
build's ``report.json`` (which records every section) stays as it was: neither runs inside
``build``. The encoder's numbers trade its CPU against the file's size; the shading's trade the
renderer's CPU against the frames' fidelity to the still's shading (``usdworld render`` keeps
the full filter). Both qualities are measured against rendered frames (``tools/bench_video.py``,
``tools/bench_flythrough.py --quality``).
"""

from __future__ import annotations

from dataclasses import dataclass

from usdworld.parameters.base import param

#: libx264's speed presets, fastest first.
X264_PRESETS = (
    "ultrafast",
    "superfast",
    "veryfast",
    "faster",
    "fast",
    "medium",
    "slow",
    "slower",
    "veryslow",
    "placebo",
)
#: libx264's motion search methods (``--me``), cheapest first.
X264_MOTION_SEARCHES = ("dia", "hex", "umh", "esa", "tesa")


@dataclass(frozen=True)
class VideoParams:
    """How videos are encoded (libx264, yuv420p); each field documents its unit, meaning and origin."""

    crf: int = param(
        20,
        "1 (libx264 constant rate factor, 0-51)",
        "Quality the encoder holds every frame to: lower keeps more detail and writes a larger file.",
        "convention: x264's visually near-lossless range (about 18-23); "
        "the value videos were always written with",
    )

    preset: str = param(
        "veryfast",
        "libx264 preset name",
        "The encoder's speed preset: the defaults of every analysis setting below it.",
        "tuned: tools/bench_video.py on the fly-through's 120 frames at 1280x640 (synthetic seed 3, "
        "session 12, two runs): with the motion settings below, 'superfast' and 'ultrafast' cost 1.5-1.6 "
        "and 1.0-1.1 s of encoder CPU against 1.7 s, but write 2.83 and 3.5 MB against 1.56 MB "
        "(they turn off the macroblock tree)",
    )

    motion_search: str = param(
        "dia",
        "libx264 --me method",
        "How far the encoder searches for each block's motion vector: 'dia' (diamond, radius 1) "
        "instead of the preset's 'hex' (hexagon, radius 2): a quarter less encoder CPU for a slightly "
        "larger file at the same measured quality (origin).",
        "tuned: tools/bench_video.py on the fly-through's 120 frames at 1280x640 (synthetic seed 3, "
        "session 12, two runs of 3): with subpixel_refinement 1, the encoder's CPU 2.34 / 2.50 -> "
        "1.73 / 1.71 s, the file 1.38 -> 1.56 MB; against the rendered frames RGB PSNR 36.83 -> 36.88 dB, "
        "luma PSNR 41.50 -> 41.46 dB, luma SSIM 0.9914 -> 0.9911",
    )

    subpixel_refinement: int = param(
        1,
        "1 (libx264 --subme level, 0-11)",
        "Sub-pixel motion estimation and mode decision effort: 1 (one quarter-pixel iteration, SAD "
        "mode decision) instead of the preset's 2. 0 (full pixels only) saved another 0.1-0.2 s of CPU "
        "at about the same quality (luma PSNR 41.40 dB, SSIM 0.9910) but has no sub-pixel motion vectors.",
        "tuned: with motion_search (same measurement)",
    )

    shadow_taps: int = param(
        1,
        "count (bilinear depth comparisons per shaded pixel)",
        "The shadow filter of the fly-through's frames: 1 is one hardware-filtered comparison (a 2x2 "
        "PCF: a penumbra one shadow texel wide); 4 is the still's 3x3 PCF (`usdworld render` always "
        "uses it). The cheaper filter hardens shadow edges slightly; the frames differ from the 3x3 "
        "filter's far less than the encoder changes them (origin).",
        "tuned: tools/bench_flythrough.py --quality on the fly-through of synthetic seed 3 (120 frames "
        "at 1280x640, session 13): 1 tap against 4: 8-13 ms less CPU per frame (of 95-105); the frames "
        "against the 3x3 filter's: PSNR 45.5 dB (worst frame 43.2 dB), luma SSIM 0.996 (worst 0.992), "
        "0.8 % of pixels off by more than 8 levels, all on shadow edges; the encoder (crf 20) alone is at "
        "36.9 dB against the rendered frames",
    )

    cull_back_faces: bool = param(
        True,
        "flag",
        "The fly-through's frames leave out the faces of closed meshes turned away from the camera "
        "(back-face culling, in the depth pre-pass and the lit pass; :mod:`usdworld.render.winding`): "
        "a closed mesh seen from outside hides them behind its own front faces, so the same surfaces "
        "show while half of each mesh's faces are not rasterised. Meshes that do not close up, and "
        "any batch whose box the camera is in, are drawn whole. Pixels change only where a face "
        "ties in depth with another or a pixel centre falls exactly on a silhouette edge (origin).",
        "geometry: a ray's first hit on a closed mesh from outside is a front face; measured with "
        "tools/bench_flythrough.py --quality on the fly-through of synthetic seed 3 (120 frames at "
        "1280x640, session 14) -- a frame's instructions 34 % fewer (callgrind), its CPU 25-35 % less; "
        "against the frames with every face drawn 0.006 % of the pixels differ (specks at depth ties and "
        "silhouette edges), PSNR 58.1 dB, worst frame 54.4 dB, luma SSIM 0.9998",
    )

    near_first: bool = param(
        True,
        "flag",
        "The fly-through's frames are drawn without a depth pre-pass: the lit pass draws near surfaces "
        "first (one asset's parts, i.e. the batches placed by the same transforms, together; their "
        "instances nearest first) and writes the depth, so most hidden fragments fail the depth test "
        "before they are shaded, and no surface is rasterised twice. The same surfaces show; where one "
        "asset's parts tie in depth the first in the scene's order still wins (origin).",
        "geometry: the nearest surface wins the depth test in any drawing order; measured with "
        "tools/bench_flythrough.py on the fly-through of synthetic seed 3 (120 frames at "
        "1280x640, session 15) -- a frame's instructions 15 % fewer (callgrind), its CPU 3-4 % less under load; "
        "fragments shaded 1.23x the pixels drawn (nearest first by each batch's own distance: 1.19x, "
        "but its order flips ties between an asset's parts, 10-300 pixels a frame); 0-3 pixels a frame "
        "differ from the frames with the pre-pass",
    )

    def __post_init__(self) -> None:
        if self.shadow_taps not in (1, 4):
            raise ValueError(f"video.shadow_taps must be 1 or 4, got {self.shadow_taps}")
        if int(self.crf) != self.crf or not 0 <= self.crf <= 51:
            raise ValueError(f"video.crf must be a whole number in 0..51, got {self.crf}")
        if self.preset not in X264_PRESETS:
            raise ValueError(f"video.preset must be one of {', '.join(X264_PRESETS)}, got {self.preset!r}")
        if self.motion_search not in X264_MOTION_SEARCHES:
            raise ValueError(
                f"video.motion_search must be one of {', '.join(X264_MOTION_SEARCHES)}, "
                f"got {self.motion_search!r}"
            )
        s = self.subpixel_refinement
        if int(s) != s or not 0 <= s <= 11:
            raise ValueError(f"video.subpixel_refinement must be a whole number in 0..11, got {s}")

    def x264_arguments(self) -> list[str]:
        """ffmpeg output arguments that apply these settings to libx264."""
        return [
            "-crf",
            str(int(self.crf)),
            "-preset",
            self.preset,
            "-x264-params",
            f"me={self.motion_search}:subme={int(self.subpixel_refinement)}",
        ]
