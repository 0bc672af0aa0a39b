"""The compiled time warps behind :func:`adverbs.graph.player.clock_of` and :func:`~adverbs.graph.player.generic_of`.

Row by row, the arithmetic of :func:`adverbs.interp.timewarp.clock_time` and
:func:`~adverbs.interp.timewarp.generic_time` (piecewise linear between keytimes, clipped to the first and last
piece), with whole cycles added for times outside one; a test holds them to the NumPy functions. The graph
converts between generic and clock time dozens of times a frame for a few creatures at a time, where NumPy's
per-call cost is the whole cost.
"""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True)
def clock_rows(g, keytimes, generic, out):  # pragma: no cover - compiled
    """``out[i]``: clock time of generic time ``g[i]`` under ``keytimes[i]`` (``g < 0``, ``g ≥ 1``: other cycles)."""
    n = generic.shape[0]
    for i in range(g.shape[0]):
        lap = math.floor(g[i])
        t = g[i] - lap
        m = 0
        for k in range(1, n - 1):
            if generic[k] <= t:
                m += 1
        m = min(max(m, 0), n - 2)
        k0, k1 = keytimes[i, m], keytimes[i, m + 1]
        out[i] = (k0 + (t - generic[m]) / (generic[m + 1] - generic[m]) * (k1 - k0)) + lap * keytimes[i, n - 1]


@njit(cache=True)
def generic_rows(clock, keytimes, generic, out):  # pragma: no cover - compiled
    """``out[i]``: generic time of clock time ``clock[i]`` under ``keytimes[i]``: the inverse of :func:`clock_rows`."""
    n = generic.shape[0]
    for i in range(clock.shape[0]):
        end = keytimes[i, n - 1]
        lap = math.floor(clock[i] / end)
        c = clock[i] - lap * end
        m = 0
        for k in range(1, n - 1):
            if keytimes[i, k] <= c:
                m += 1
        m = min(max(m, 0), n - 2)
        k0, k1 = keytimes[i, m], keytimes[i, m + 1]
        out[i] = (generic[m] + (generic[m + 1] - generic[m]) * (c - k0) / (k1 - k0)) + lap
