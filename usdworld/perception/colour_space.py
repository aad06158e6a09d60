"""Colour spaces: sRGB encoding, linear RGB and CIELAB (D65), pure numpy.

Colours are arrays whose last axis holds three channels. Linear RGB uses the sRGB (BT.709)
primaries and white point, as USD colour values do; CIELAB is relative to the D65 white.

Example:
    >>> import numpy as np
    >>> np.round(linear_to_lab(np.array([1.0, 1.0, 1.0])), 6)
    array([100.,   0.,   0.])
"""

from __future__ import annotations

import functools

import numpy as np

#: XYZ of the sRGB primaries (IEC 61966-2-1), rows X, Y, Z; applied as ``xyz = M @ rgb``.
XYZ_FROM_LINEAR = np.array(
    [
        [0.4124564, 0.3575761, 0.1804375],
        [0.2126729, 0.7151522, 0.0721750],
        [0.0193339, 0.1191920, 0.9503041],
    ]
)
#: XYZ of the D65 white (Y = 1), the white of sRGB.
D65_WHITE = XYZ_FROM_LINEAR.sum(axis=1)


def srgb_to_linear(srgb: np.ndarray) -> np.ndarray:
    """Decode sRGB values in [0, 1] to linear RGB (IEC 61966-2-1 transfer function).

    Args:
        srgb: (..., 3) float sRGB-encoded values in [0, 1].

    Returns:
        (..., 3) float64 linear RGB.
    """
    s = np.asarray(srgb, dtype=np.float64)
    return np.where(s <= 0.04045, s / 12.92, ((s + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(linear: np.ndarray) -> np.ndarray:
    """Encode linear RGB to sRGB, clipped to [0, 1].

    Args:
        linear: (..., 3) float linear RGB.

    Returns:
        (..., 3) float64 sRGB-encoded values in [0, 1].
    """
    x = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1.0 / 2.4) - 0.055)


def uint8_to_linear(rgb: np.ndarray) -> np.ndarray:
    """Decode 8-bit sRGB pixels to linear RGB.

    Args:
        rgb: (..., 3) uint8 sRGB pixels.

    Returns:
        (..., 3) float64 linear RGB in [0, 1].
    """
    return _decode_table()[np.asarray(rgb, dtype=np.uint8)]


@functools.lru_cache(maxsize=1)
def _decode_table() -> np.ndarray:
    """(256,) float64 linear value of each 8-bit sRGB code, made once (read-only)."""
    table = srgb_to_linear(np.arange(256) / 255.0)
    table.setflags(write=False)
    return table


def linear_to_lab(linear: np.ndarray) -> np.ndarray:
    """Linear RGB to CIELAB (D65 white, CIE 1976).

    Args:
        linear: (..., 3) float linear RGB (values outside [0, 1] are clipped).

    Returns:
        (..., 3) float64 L* (0..100), a*, b*.
    """
    rgb = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    xyz = rgb @ XYZ_FROM_LINEAR.T / D65_WHITE
    eps, kappa = 216.0 / 24389.0, 24389.0 / 27.0
    f = np.where(xyz > eps, np.cbrt(xyz), (kappa * xyz + 16.0) / 116.0)
    lab = np.empty_like(f)
    lab[..., 0] = 116.0 * f[..., 1] - 16.0
    lab[..., 1] = 500.0 * (f[..., 0] - f[..., 1])
    lab[..., 2] = 200.0 * (f[..., 1] - f[..., 2])
    return lab
