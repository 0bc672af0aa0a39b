"""The compiled loop behind :func:`adverbs.kinematics.quat.unwrap_euler`: sample by sample, each series takes the
branch of its Euler angles nearest its previous sample (the same arithmetic as the NumPy loop it replaced, which
``tests/test_quat.py`` keeps as the reference)."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def unwrap(a, alt, near, start):  # pragma: no cover - compiled
    """``a, alt (F, N, 3)``: each sample's two Tait–Bryan solutions; ``near (N, 3)``: where the first sample lands
    when ``start`` is 0. Returns the continuous angles ``(F, N, 3)``."""
    two_pi = 2.0 * np.pi
    out = a.copy()
    prev = np.empty(3)
    c = np.empty((2, 3))
    for n in range(a.shape[1]):
        for i in range(start, a.shape[0]):
            for k in range(3):
                prev[k] = out[i - 1, n, k] if i > 0 else near[n, k]
            cost0 = 0.0
            cost1 = 0.0
            for k in range(3):
                c[0, k] = a[i, n, k] + two_pi * np.rint((prev[k] - a[i, n, k]) / two_pi)
                c[1, k] = alt[i, n, k] + two_pi * np.rint((prev[k] - alt[i, n, k]) / two_pi)
                cost0 += (c[0, k] - prev[k]) ** 2
                cost1 += (c[1, k] - prev[k]) ** 2
            pick = 1 if cost1 < cost0 else 0
            for k in range(3):
                out[i, n, k] = c[pick, k]
    return out
