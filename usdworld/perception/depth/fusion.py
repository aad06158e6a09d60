"""Per-object depth from several cues, fused by inverse-variance weighting.

Cues (each a :class:`DepthCue`; an unavailable cue keeps its name with ``depth_m`` and
``sigma_m`` None, so provenance shows every cue that was considered):

``contact``
    Depth of the object's ground contact point from the camera (given by the caller,
    None when the bottom is truncated by the image edge or occluded). One pixel of
    error in the contact row ``v`` moves ``d = f h / (v - v_horizon)`` by
    ``d^2 / (f h)``, so ``sigma = sqrt((e_v d^2 / (f h))^2 + (r_c d)^2)`` with
    ``e_v = 1 px`` and a floor ``r_c = 1 %`` for road camber and pitch error.
``cnn``
    Robust mean of the depth map over the object's mask eroded by 2 px (mask edges mix
    foreground and background), pixels of occluding objects and invalid depth
    excluded: the interquartile mean (mean of the values between the 25th and 75th
    percentiles). ``sigma = r_n d`` with ``r_n = 10 %`` (typical relative error of
    monocular networks on KITTI/Cityscapes after alignment). Pass a network's or a
    file's depth map here, never the ``ground`` backend's (which is the ground behind
    the object, not the object).
``height``
    Class height prior: ``d = f H / h_px`` for an object of height ``H`` metres seen
    ``h_px`` pixels tall (None when its top or bottom is cut), or the caller's depth
    from a silhouette model that includes the object's depth extent. The spread of real
    heights ``std_H``, the uncertainty of the class mean ``r_m`` (when the camera height
    is known independently of the objects) and one pixel of height error give
    ``sigma = d sqrt((std_H / H)^2 + r_m^2 + (1 / h_px)^2)``.

The numbers ``e_v``, ``r_c``, ``r_n``, ``r_m``, the erosion and the default height
spread are fields of :class:`~usdworld.parameters.PerceptionParams`.

All three sigmas grow with distance (the contact one quadratically), so near objects
are placed by their contact point and truncated or occluded ones by the others.

Example:
    >>> cues = [DepthCue("contact", 8.0, 0.1), DepthCue("cnn", 9.0, 0.9), DepthCue("height", None, None)]
    >>> fused = fuse(cues)
    >>> fused.method, round(fused.depth_m, 2)
    ('contact', 8.01)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usdworld.errors import InputError, LayoutError
from usdworld.io.types import DepthMap
from usdworld.parameters.perception import DEFAULT_PERCEPTION, PerceptionParams

CUE_NAMES = ("contact", "cnn", "height")


@dataclass(frozen=True)
class DepthCue:
    """One estimate of an object's depth.

    Attributes:
        name: ``contact``, ``cnn`` or ``height``.
        depth_m: depth along the optical axis, metres (> 0), or None when unavailable.
        sigma_m: standard deviation, metres (> 0), or None when unavailable.
        note: why the cue is unavailable, or how it was computed (for provenance).
    """

    name: str
    depth_m: float | None
    sigma_m: float | None
    note: str = ""

    def __post_init__(self) -> None:
        if (self.depth_m is None) != (self.sigma_m is None):
            raise InputError(f"depth cue {self.name}: depth_m and sigma_m must both be set or both None")
        if self.depth_m is not None and self.sigma_m is not None:
            if not (np.isfinite(self.depth_m) and self.depth_m > 0):
                raise InputError(f"depth cue {self.name}: depth_m must be finite and > 0, got {self.depth_m}")
            if not (np.isfinite(self.sigma_m) and self.sigma_m > 0):
                raise InputError(f"depth cue {self.name}: sigma_m must be finite and > 0, got {self.sigma_m}")
            object.__setattr__(self, "depth_m", float(self.depth_m))
            object.__setattr__(self, "sigma_m", float(self.sigma_m))

    @property
    def available(self) -> bool:
        """True when the cue has a value."""
        return self.depth_m is not None


@dataclass(frozen=True)
class FusedDepth:
    """An object's depth after fusion.

    Attributes:
        depth_m: inverse-variance weighted mean of the available cues, metres.
        sigma_m: its standard deviation ``1 / sqrt(sum of weights)``, metres.
        method: the name of the cue holding at least ``dominant_share`` of the weight (or
            the only one), else ``fused``.
        cues: every cue considered, available or not, in input order.
        chi2: ``sum w_i (d_i - d)^2`` over available cues; well above their count - 1
            means the cues disagree (e.g. an undetected occlusion).
    """

    depth_m: float
    sigma_m: float
    method: str
    cues: tuple[DepthCue, ...]
    chi2: float = 0.0


def erode(mask: np.ndarray, radius_px: int) -> np.ndarray:
    """Binary erosion with a (2r+1) x (2r+1) square; pixels outside the image count as background.

    Args:
        mask: (H, W) bool.
        radius_px: r >= 0.

    Returns:
        (H, W) bool.
    """
    out = np.asarray(mask, dtype=bool).copy()
    for _ in range(radius_px):
        p = np.pad(out, 1, constant_values=False)
        acc = p[1:-1, 1:-1].copy()
        for dv in (0, 1, 2):
            for du in (0, 1, 2):
                acc &= p[dv : dv + out.shape[0], du : du + out.shape[1]]
        out = acc
    return out


def interquartile_mean(values: np.ndarray) -> float:
    """Mean of the values between the 25th and 75th percentiles (inclusive).

    Args:
        values: (N,) finite values, N >= 1.
    """
    lo, hi = np.percentile(values, [25.0, 75.0])
    mid = values[(values >= lo) & (values <= hi)]
    return float(mid.mean()) if mid.size else float(np.median(values))


def contact_sigma_m(
    depth_m: float, fy: float, camera_height_m: float, params: PerceptionParams = DEFAULT_PERCEPTION
) -> float:
    """Sigma of the ground-contact cue at ``depth_m`` (module docstring), metres."""
    geometric = params.contact_row_error_px * depth_m**2 / (fy * camera_height_m)
    return float(np.hypot(geometric, params.contact_rel_sigma * depth_m))


def _cnn_cue(
    mask: np.ndarray, occluders: np.ndarray, depth_map: DepthMap | None, params: PerceptionParams
) -> DepthCue:
    if depth_map is None:
        return DepthCue("cnn", None, None, "no depth map")
    if depth_map.depth_m.shape != mask.shape:
        raise InputError(f"object depth: depth map is {depth_map.depth_m.shape}, mask is {mask.shape}")
    usable = ~occluders & depth_map.valid
    pixels = erode(mask, params.erosion_px) & usable
    how = f"interquartile mean over mask eroded {params.erosion_px} px"
    if pixels.sum() < params.min_cnn_pixels:
        pixels = mask & usable
        how = "interquartile mean over mask (too thin to erode)"
    n = int(pixels.sum())
    if n < params.min_cnn_pixels:
        return DepthCue("cnn", None, None, f"{n} unoccluded pixels with depth (need {params.min_cnn_pixels})")
    d = interquartile_mean(depth_map.depth_m[pixels].astype(np.float64))
    return DepthCue("cnn", d, params.cnn_rel_sigma * d, f"{how}, {n} px, {depth_map.source}")


def object_depth_cues(
    mask: np.ndarray,
    occluders: np.ndarray,
    contact_depth_m: float | None,
    depth_map: DepthMap | None,
    class_height_m: float,
    height_px: float | None,
    fy: float,
    *,
    camera_height_m: float,
    class_height_std_m: float | None = None,
    height_depth_m: float | None = None,
    class_mean_rel_sigma: float = 0.0,
    params: PerceptionParams = DEFAULT_PERCEPTION,
) -> list[DepthCue]:
    """Every depth cue of one object (module docstring for the models and sigmas).

    Args:
        mask: (H, W) bool, the object's pixels.
        occluders: (H, W) bool, pixels of objects in front of it (excluded from the CNN cue).
        contact_depth_m: depth of the ground contact point, or None when the bottom is
            truncated or occluded.
        depth_map: (H, W) metric depth map from a network or file, or None.
        class_height_m: typical height of the object's class, metres (> 0).
        height_px: the object's height in the image, pixels, or None when its top or
            bottom is cut.
        fy: vertical focal length, pixels.
        camera_height_m: camera height above the ground, metres (contact sigma).
        class_height_std_m: spread of the class's real heights, metres; default
            ``params.height_rel_std`` of ``class_height_m``.
        height_depth_m: the depth the caller found for ``height_px`` with a model of the
            object's silhouette (:mod:`usdworld.layout.silhouette`), replacing the flat
            ``f H / h``; its sigma is the same.
        class_mean_rel_sigma: relative uncertainty of the class's mean height, added to
            the height cue's sigma (``params.height_mean_rel_sigma`` when the camera height
            is known independently of the objects, else 0).
        params: the cues' error model (module docstring).

    Returns:
        ``[contact, cnn, height]`` cues; unavailable ones have ``depth_m`` None and a
        note saying why.

    Raises:
        InputError: mismatched shapes or non-positive parameters.
    """
    mask = np.asarray(mask, dtype=bool)
    occluders = np.asarray(occluders, dtype=bool)
    if mask.ndim != 2 or occluders.shape != mask.shape:
        raise InputError(
            f"object depth: mask {mask.shape} and occluders {occluders.shape} must be one (H, W) shape"
        )
    for label, value in (
        ("fy", fy),
        ("camera_height_m", camera_height_m),
        ("class_height_m", class_height_m),
    ):
        if not (np.isfinite(value) and value > 0):
            raise InputError(f"object depth: {label} must be > 0, got {value}")
    std_h = params.height_rel_std * class_height_m if class_height_std_m is None else float(class_height_std_m)
    if not (np.isfinite(std_h) and std_h > 0):
        raise InputError(f"object depth: class_height_std_m must be > 0, got {class_height_std_m}")

    if contact_depth_m is None:
        contact = DepthCue("contact", None, None, "bottom truncated or occluded")
    elif not (np.isfinite(contact_depth_m) and contact_depth_m > 0):
        contact = DepthCue("contact", None, None, f"contact point not on the ground ({contact_depth_m})")
    else:
        contact = DepthCue(
            "contact",
            contact_depth_m,
            contact_sigma_m(contact_depth_m, fy, camera_height_m, params),
            f"ground contact row, {params.contact_row_error_px:g} px row error",
        )

    if height_px is None:
        height = DepthCue("height", None, None, "top or bottom cut")
    elif not (np.isfinite(height_px) and height_px >= 1):
        height = DepthCue("height", None, None, f"height {height_px} px too small")
    else:
        if height_depth_m is not None and np.isfinite(height_depth_m) and height_depth_m > 0:
            d = float(height_depth_m)
            how = f"silhouette of a {class_height_m:g} m object {height_px:.1f} px tall"
        else:
            d = fy * class_height_m / height_px
            how = f"f*H/h = {fy:.1f}*{class_height_m:g}/{height_px:.1f}"
        sigma = d * float(np.sqrt((std_h / class_height_m) ** 2 + class_mean_rel_sigma**2 + (1.0 / height_px) ** 2))
        height = DepthCue("height", d, sigma, how)

    return [contact, _cnn_cue(mask, occluders, depth_map, params), height]


def fuse(
    cues: list[DepthCue] | tuple[DepthCue, ...], params: PerceptionParams = DEFAULT_PERCEPTION
) -> FusedDepth:
    """Inverse-variance weighted depth of the available cues.

    Args:
        cues: the object's cues (all of them, available or not).
        params: ``dominant_share`` names the method.

    Returns:
        The fused depth; ``cues`` is kept whole for provenance.

    Raises:
        LayoutError: no cue is available (the object cannot be placed).
    """
    cues = tuple(cues)
    avail = [c for c in cues if c.available]
    if not avail:
        names = ", ".join(f"{c.name} ({c.note or 'unavailable'})" for c in cues) or "none given"
        raise LayoutError(f"object depth: no depth cue is available: {names}")
    d = np.array([c.depth_m for c in avail], dtype=np.float64)
    w = 1.0 / np.array([c.sigma_m for c in avail], dtype=np.float64) ** 2
    depth = float(np.sum(w * d) / np.sum(w))
    sigma = float(1.0 / np.sqrt(np.sum(w)))
    share = w / np.sum(w)
    top = int(np.argmax(share))
    method = avail[top].name if share[top] >= params.dominant_share else "fused"
    chi2 = float(np.sum(w * (d - depth) ** 2))
    return FusedDepth(depth_m=depth, sigma_m=sigma, method=method, cues=cues, chi2=chi2)
