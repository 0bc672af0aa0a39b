"""The time warp of one row of keytimes, for the compiled loops: the sampler's
:func:`adverbs.verb._sampling_kernel.phase` and the graph's clocks (:mod:`adverbs.graph._time_kernel`). Each
mirrors the NumPy arithmetic of :mod:`adverbs.interp.timewarp` (named in its docstring) in the same order; a test
holds them equal.
"""

from __future__ import annotations

import math

from numba import njit

RAMP = 0.25  # the fraction of a keytime's shorter piece over which the warp's rate turns there (timewarp)
EXCESS = 0.05  # ... and no longer than puts more than this fraction of either piece's generic stretch off its own rate
TINY = 1e-300  # (a keytime whose rate is a piece's own puts none off it)


@njit(cache=True, inline="always")
def slope(keytimes, generic, n, m):  # pragma: no cover - compiled
    """``timewarp.slopes``' entry ``m``: dt/dT at keytime ``m`` of ``keytimes (n,)`` and the seconds over which the
    rate turns to it on either side."""
    a = (m - 1) if m > 0 else n - 2
    b = m if m < n - 1 else 0
    ha = keytimes[a + 1] - keytimes[a]
    hb = keytimes[b + 1] - keytimes[b]
    ga = generic[a + 1] - generic[a]
    gb = generic[b + 1] - generic[b]
    d = (ga * hb / ha + gb * ha / hb) / (ha + hb)
    e = RAMP * min(min(ha, hb), min(ga, gb) / d)
    return d, min(e, EXCESS * ga / max(abs(d - ga / ha), TINY), EXCESS * gb / max(abs(d - gb / hb), TINY))


@njit(cache=True, inline="always")
def piece(edges, n, x):  # pragma: no cover - compiled
    """The piece ``m`` of ``edges[m] ≤ x < edges[m + 1]``, the first and last for times outside."""
    m = 0
    while m < n - 2 and edges[m + 1] <= x:
        m += 1
    return m


@njit(cache=True, inline="always")
def _rates(keytimes, generic, n, m):  # pragma: no cover - compiled
    """Piece ``m``'s ramps and rates (at its keytimes, in its middle): ``timewarp._piece``."""
    d0, e0 = slope(keytimes, generic, n, m)
    d1, e1 = slope(keytimes, generic, n, m + 1)
    h = keytimes[m + 1] - keytimes[m]
    c = (generic[m + 1] - generic[m] - 0.5 * (e0 * d0 + e1 * d1)) / (h - 0.5 * (e0 + e1))
    return e0, e1, d0, d1, c


@njit(cache=True, inline="always")
def warp(keytimes, generic, n, clock):  # pragma: no cover - compiled
    """``timewarp.generic_time`` of one clock time under one row of keytimes ``(n,)``."""
    if clock <= keytimes[0]:
        return generic[0] + slope(keytimes, generic, n, 0)[0] * (clock - keytimes[0])
    if clock >= keytimes[n - 1]:
        return generic[n - 1] + slope(keytimes, generic, n, n - 1)[0] * (clock - keytimes[n - 1])
    m = piece(keytimes, n, clock)
    e0, e1, d0, d1, c = _rates(keytimes, generic, n, m)
    s = clock - keytimes[m]
    if s < e0:
        return generic[m] + s * (d0 + 0.5 * (c - d0) * s / e0)
    u = keytimes[m + 1] - clock
    if u < e1:
        return generic[m + 1] - u * (d1 + 0.5 * (c - d1) * u / e1)
    return generic[m] + 0.5 * e0 * (d0 + c) + c * (s - e0)


@njit(cache=True, inline="always")
def _root(d, c, e, x):  # pragma: no cover - compiled
    """``timewarp._root``: the ``s ≥ 0`` of ``s (d + (c − d) s / 2e) = x``."""
    return 2.0 * x / (d + math.sqrt(max(d * d + 2.0 * (c - d) * x / e, 0.0)))


@njit(cache=True, inline="always")
def unwarp(keytimes, generic, n, t):  # pragma: no cover - compiled
    """``timewarp.clock_time`` of one generic time under one row of keytimes ``(n,)``: :func:`warp`'s inverse."""
    if t <= generic[0]:
        return keytimes[0] + (t - generic[0]) / slope(keytimes, generic, n, 0)[0]
    if t >= generic[n - 1]:
        return keytimes[n - 1] + (t - generic[n - 1]) / slope(keytimes, generic, n, n - 1)[0]
    m = piece(generic, n, t)
    e0, e1, d0, d1, c = _rates(keytimes, generic, n, m)
    a = generic[m] + 0.5 * e0 * (d0 + c)
    b = generic[m + 1] - 0.5 * e1 * (d1 + c)
    if t < a:
        return keytimes[m] + _root(d0, c, e0, t - generic[m])
    if t > b:
        return keytimes[m + 1] - _root(d1, c, e1, generic[m + 1] - t)
    return keytimes[m] + e0 + (t - a) / c
