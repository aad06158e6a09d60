"""Peaks of a 1-D profile and their topographic prominence (pure numpy).

The crowns' cut (:mod:`usdworld.perception.crowns`) needs only this part of
``scipy.signal.find_peaks``; importing ``scipy.signal`` costs most of a second at
start-up, so the two steps are written out here with scipy's exact semantics:

* a *peak* is a sample, or a flat run of equal samples, whose neighbours on both sides
  are strictly lower; a run's peak is its middle sample (the left one of the two
  middles), and the first and last samples are never peaks;
* a peak's *prominence* is its height above the higher of its two bases, each base the
  lowest sample between the peak and the nearest strictly higher sample on that side
  (or the signal's end).

``tests/test_perception_peaks.py`` checks both against scipy on random signals.

Frames: sample indices (a crop's columns for the crowns).
"""

from __future__ import annotations

import numpy as np


def local_maxima(x: np.ndarray) -> np.ndarray:
    """Indices of the peaks of ``x`` (module docstring), increasing.

    Args:
        x: (n,) float64 signal without NaN.

    Returns:
        (k,) int64 peak indices.

    Example:
        >>> local_maxima(np.array([0.0, 2.0, 2.0, 2.0, 1.0, 3.0, 3.0])).tolist()
        [2]
    """
    x = np.asarray(x, dtype=np.float64)
    if len(x) < 3:
        return np.zeros(0, dtype=np.int64)
    # Runs of equal samples: their first and last index and value.
    starts = np.concatenate([[0], np.flatnonzero(x[1:] != x[:-1]) + 1])
    ends = np.concatenate([starts[1:] - 1, [len(x) - 1]])
    values = x[starts]
    inner = np.arange(1, len(starts) - 1)
    peak = (values[inner - 1] < values[inner]) & (values[inner + 1] < values[inner])
    runs = inner[peak]
    return ((starts[runs] + ends[runs]) // 2).astype(np.int64)


def prominences(x: np.ndarray, peaks: np.ndarray) -> np.ndarray:
    """Prominence of each peak of ``x`` (module docstring).

    Args:
        x: (n,) float64 signal without NaN.
        peaks: (k,) int indices of peaks of ``x``.

    Returns:
        (k,) float64 prominences (>= 0).

    Example:
        >>> x = np.array([0.0, 3.0, 1.0, 2.0, 0.0])
        >>> prominences(x, local_maxima(x)).tolist()
        [3.0, 1.0]
    """
    x = np.asarray(x, dtype=np.float64)
    out = np.empty(len(peaks), dtype=np.float64)
    for k, peak in enumerate(peaks):
        height = x[peak]
        higher_left = np.flatnonzero(x[:peak] > height)
        higher_right = np.flatnonzero(x[peak + 1 :] > height)
        lo = higher_left[-1] + 1 if len(higher_left) else 0
        hi = peak + 1 + higher_right[0] if len(higher_right) else len(x)
        left_min = x[lo : peak + 1].min()
        right_min = x[peak:hi].min()
        out[k] = height - max(left_min, right_min)
    return out
