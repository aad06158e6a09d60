"""Colour differences in CIELAB: CIE76 (Euclidean) and CIEDE2000.

CIEDE2000 follows Sharma, Wu and Dalal, "The CIEDE2000 color-difference formula:
implementation notes, supplementary test data, and mathematical observations", Color
Research & Application 30(1), 2005 (equations 1-17; ``kL = kC = kH = 1``); the tests pin
its published test pairs.
"""

from __future__ import annotations

import numpy as np


def delta_e76(lab1: np.ndarray, lab2: np.ndarray) -> np.ndarray:
    """CIE76 colour difference: the Euclidean distance in CIELAB.

    Args:
        lab1: (..., 3) float L*, a*, b*.
        lab2: (..., 3) float L*, a*, b* (broadcast against ``lab1``).

    Returns:
        (...) float64 differences.
    """
    return np.linalg.norm(np.asarray(lab1, dtype=np.float64) - np.asarray(lab2, dtype=np.float64), axis=-1)


def delta_e2000(lab1: np.ndarray, lab2: np.ndarray) -> np.ndarray:
    """CIEDE2000 colour difference (``kL = kC = kH = 1``).

    Args:
        lab1: (..., 3) float L*, a*, b*.
        lab2: (..., 3) float L*, a*, b* (broadcast against ``lab1``).

    Returns:
        (...) float64 differences.
    """
    a1, a2 = np.asarray(lab1, dtype=np.float64), np.asarray(lab2, dtype=np.float64)
    L1, A1, B1 = a1[..., 0], a1[..., 1], a1[..., 2]
    L2, A2, B2 = a2[..., 0], a2[..., 1], a2[..., 2]
    c_bar = 0.5 * (np.hypot(A1, B1) + np.hypot(A2, B2))
    g = 0.5 * (1.0 - np.sqrt(c_bar**7 / (c_bar**7 + 25.0**7)))
    ap1, ap2 = (1.0 + g) * A1, (1.0 + g) * A2
    cp1, cp2 = np.hypot(ap1, B1), np.hypot(ap2, B2)
    hp1 = np.where(cp1 == 0, 0.0, np.degrees(np.arctan2(B1, ap1)) % 360.0)
    hp2 = np.where(cp2 == 0, 0.0, np.degrees(np.arctan2(B2, ap2)) % 360.0)
    d_l = L2 - L1
    d_c = cp2 - cp1
    both = cp1 * cp2 != 0
    dh = hp2 - hp1
    dh = np.where(dh > 180.0, dh - 360.0, np.where(dh < -180.0, dh + 360.0, dh))
    dh = np.where(both, dh, 0.0)
    d_h = 2.0 * np.sqrt(cp1 * cp2) * np.sin(np.radians(dh) / 2.0)
    l_bar = 0.5 * (L1 + L2)
    cp_bar = 0.5 * (cp1 + cp2)
    h_sum = hp1 + hp2
    h_bar = np.where(
        np.abs(hp1 - hp2) <= 180.0,
        0.5 * h_sum,
        np.where(h_sum < 360.0, 0.5 * (h_sum + 360.0), 0.5 * (h_sum - 360.0)),
    )
    h_bar = np.where(both, h_bar, h_sum)
    t = (
        1.0
        - 0.17 * np.cos(np.radians(h_bar - 30.0))
        + 0.24 * np.cos(np.radians(2.0 * h_bar))
        + 0.32 * np.cos(np.radians(3.0 * h_bar + 6.0))
        - 0.20 * np.cos(np.radians(4.0 * h_bar - 63.0))
    )
    d_theta = 30.0 * np.exp(-(((h_bar - 275.0) / 25.0) ** 2))
    r_c = 2.0 * np.sqrt(cp_bar**7 / (cp_bar**7 + 25.0**7))
    s_l = 1.0 + 0.015 * (l_bar - 50.0) ** 2 / np.sqrt(20.0 + (l_bar - 50.0) ** 2)
    s_c = 1.0 + 0.045 * cp_bar
    s_h = 1.0 + 0.015 * cp_bar * t
    r_t = -np.sin(np.radians(2.0 * d_theta)) * r_c
    tl, tc, th = d_l / s_l, d_c / s_c, d_h / s_h
    return np.sqrt(tl**2 + tc**2 + th**2 + r_t * tc * th)
