"""Structural similarity (SSIM) of two images, after Wang, Bovik, Sheikh and Simoncelli (2004).

Local statistics use an 11 x 11 Gaussian window with sigma 1.5 (truncated, normalised to
sum 1) and the paper's constants ``C1 = (0.01 L)^2``, ``C2 = (0.03 L)^2`` with ``L`` the
dynamic range (255 for 8-bit images)::

    SSIM(x, y) = (2 mu_x mu_y + C1)(2 sigma_xy + C2) / ((mu_x^2 + mu_y^2 + C1)(sigma_x^2 + sigma_y^2 + C2))

The mean SSIM is averaged over the windows that lie wholly inside the image ("valid"
region, as in the paper's reference implementation). Colour images are compared on their
luma (ITU-R BT.601: 0.299 R + 0.587 G + 0.114 B).

Example:
    >>> a = np.random.default_rng(0).integers(0, 256, (32, 32)).astype(np.uint8)
    >>> round(ssim(a, a), 6)
    1.0
"""

from __future__ import annotations

import cv2
import numpy as np

from usdworld.errors import InputError

WINDOW = 11
SIGMA = 1.5
K1, K2 = 0.01, 0.03


def gaussian_window(size: int = WINDOW, sigma: float = SIGMA) -> np.ndarray:
    """(size, size) float64 Gaussian window summing to 1."""
    x = np.arange(size, dtype=np.float64) - (size - 1) / 2.0
    g = np.exp(-(x**2) / (2.0 * sigma**2))
    w = np.outer(g, g)
    return w / w.sum()


def to_luma(image: np.ndarray) -> np.ndarray:
    """(H, W) float64 luma of a (H, W) grey or (H, W, 3) RGB image."""
    a = np.asarray(image, dtype=np.float64)
    if a.ndim == 2:
        return a
    if a.ndim == 3 and a.shape[2] == 3:
        return a @ np.array([0.299, 0.587, 0.114])
    raise InputError(f"SSIM: need an (H, W) or (H, W, 3) image, got shape {a.shape}")


def ssim_map(x: np.ndarray, y: np.ndarray, data_range: float = 255.0) -> np.ndarray:
    """(H-10, W-10) float64 local SSIM over the valid windows.

    Args:
        x: (H, W) or (H, W, 3) image.
        y: image of the same shape.
        data_range: the dynamic range L of the pixel values.
    """
    a, b = to_luma(x), to_luma(y)
    if a.shape != b.shape:
        raise InputError(f"SSIM: images differ in size, {a.shape} vs {b.shape}; resize one first")
    if min(a.shape) < WINDOW:
        raise InputError(f"SSIM: images must be at least {WINDOW}x{WINDOW} pixels, got {a.shape}")
    if not data_range > 0:
        raise InputError(f"SSIM: data_range must be > 0, got {data_range}")
    w = gaussian_window()

    def filt(img: np.ndarray) -> np.ndarray:
        out = cv2.filter2D(img, cv2.CV_64F, w, borderType=cv2.BORDER_REFLECT)
        r = WINDOW // 2
        return out[r:-r, r:-r]

    c1, c2 = (K1 * data_range) ** 2, (K2 * data_range) ** 2
    mu_a, mu_b = filt(a), filt(b)
    var_a = filt(a * a) - mu_a**2
    var_b = filt(b * b) - mu_b**2
    cov = filt(a * b) - mu_a * mu_b
    num = (2 * mu_a * mu_b + c1) * (2 * cov + c2)
    den = (mu_a**2 + mu_b**2 + c1) * (var_a + var_b + c2)
    return num / den


def ssim(x: np.ndarray, y: np.ndarray, data_range: float = 255.0) -> float:
    """Mean SSIM of two images (see :func:`ssim_map`); 1.0 for identical images."""
    return float(ssim_map(x, y, data_range).mean())
