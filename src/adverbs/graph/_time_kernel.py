"""The compiled time warps behind :func:`adverbs.graph.clocks.clock_of` and :func:`~adverbs.graph.clocks.generic_of`.

Row by row, the arithmetic of :func:`adverbs.interp.timewarp.clock_time` and
:func:`~adverbs.interp.timewarp.generic_time` (piecewise quadratic between keytimes, its rate continuous:
:mod:`adverbs.interp._warp_scalars`), with whole cycles added for times outside one; a test holds them to the NumPy
functions. The graph converts between generic and clock time dozens of times a frame for a few creatures at a
time, where NumPy's per-call cost is the whole cost.
"""

from __future__ import annotations

import math

from numba import njit

from ..feet._planting_scalars import hold_mode
from ..interp._warp_scalars import unwarp, warp


@njit(cache=True)
def clock_rows(g, keytimes, generic, out):  # pragma: no cover - compiled
    """``out[i, j]``: clock time of generic time ``g[i, j]`` under ``keytimes[i]`` (``g < 0``, ``g ≥ 1``: other cycles)."""
    n = generic.shape[0]
    for i in range(g.shape[0]):
        for j in range(g.shape[1]):
            out[i, j] = _clock(g[i, j], keytimes[i], generic, n)


@njit(cache=True, inline="always")
def _clock(g, keytimes, generic, n):  # pragma: no cover - compiled
    """Clock time of generic time ``g`` under one row of ``keytimes (N,)``."""
    lap = math.floor(g)
    return unwarp(keytimes, generic, n, g - lap) + lap * keytimes[n - 1]


@njit(cache=True)
def generic_rows(clock, keytimes, generic, out):  # pragma: no cover - compiled
    """``out[i, j]``: generic time of clock time ``clock[i, j]`` under ``keytimes[i]``: the inverse of :func:`clock_rows`."""
    n = generic.shape[0]
    for i in range(clock.shape[0]):
        for j in range(clock.shape[1]):
            out[i, j] = _generic(clock[i, j], keytimes[i], generic, n)


@njit(cache=True, inline="always")
def _generic(clock, keytimes, generic, n):  # pragma: no cover - compiled
    """Generic time of clock time ``clock`` under one row of ``keytimes (N,)``."""
    end = keytimes[n - 1]
    lap = math.floor(clock / end)
    return warp(keytimes, generic, n, clock - lap * end) + lap


@njit(cache=True)
def hold_rows(g, rows, opens, times, cols, cyclic, held, roll, swing):  # pragma: no cover - compiled
    """For the creatures ``rows (n,)`` of one verb at generic times ``g (C,)``: whether each of its holds is open, how
    far its foot has rolled off and how much of the least swing lift it has, written to columns ``cols (L,)`` of
    ``held (C, F)``, ``roll (C, F)`` and ``swing (C, F)``.

    :func:`adverbs.feet.planter.hold_modes` and :func:`~adverbs.feet.planter.swing_lifts` row by row
    (``opens (L,)``, ``times (C, L, 3)``), on the cycle ``g`` falls in (cyclic) or clipped to the motion.
    """
    for i in range(rows.shape[0]):
        c = rows[i]
        t = g[c] - math.floor(g[c]) if cyclic else min(max(g[c], 0.0), 1.0)
        for k in range(opens.shape[0]):
            held[c, cols[k]], roll[c, cols[k]], swing[c, cols[k]] = hold_mode(cyclic, t, opens[k], times[c, k])


@njit(cache=True)
def later_rows(g, seconds, keytimes, generic, out):  # pragma: no cover - compiled
    """``out[i, j]``: the generic time ``seconds`` of clock time after generic time ``g[i, j]`` under ``keytimes[i]``
    (:func:`clock_rows`, the seconds added, then :func:`generic_rows`, in one pass)."""
    n = generic.shape[0]
    for i in range(g.shape[0]):
        for j in range(g.shape[1]):
            out[i, j] = _generic(_clock(g[i, j], keytimes[i], generic, n) + seconds, keytimes[i], generic, n)
