"""Scalar rules of planted feet shared by the compiled loops: the planter's (:mod:`._planting_kernel`) and a verb
graph's hold lookup (:mod:`adverbs.graph._time_kernel`) and decaying offsets (:mod:`adverbs.graph._blend_kernel`).

Each mirrors a NumPy function of :mod:`adverbs.feet.planter` (named in its docstring), with the same arithmetic.
A module of its own, so a graph's kernels need not load the planter's.
"""

from __future__ import annotations

import math

from numba import njit

SWING_LANDING = 0.3  # fraction of a swing (toe-off to the next landing) over which its least lift fades to none
FLAT_TO_THE_END = 1e-9  # a hold whose heel-off is this near its toe-off does not roll its foot off (a stand's, [0, 1, 1]:
# blended at a creature's adverbs, its heel-off came out 1 - 1e-16, and at the stand's end the foot was "rolled" 4e-8,
# enough for the planter to take it for one lifting off and leave it unheld)


@njit(cache=True, inline="always")
def smoothstep(x):  # pragma: no cover - compiled
    """``planting._smoothstep``."""
    x = min(max(x, 0.0), 1.0)
    return x * x * (3.0 - 2.0 * x)


@njit(cache=True, inline="always")
def spring(x0, v0, t, halflife, ln2):  # pragma: no cover - compiled
    """``planting._spring``: a critically damped offset ``x0`` with velocity ``v0``, ``t`` seconds on (``ln2``: log 2); before it
    starts (``t < 0``), ``x0``."""
    if t < 0.0:
        return x0
    y = 2.0 * ln2 / halflife
    if y * t > 700.0:  # long settled: exp would underflow, which libm handles slowly (errno); under 1e-300 of x0
        return 0.0
    return (x0 + (v0 + y * x0) * t) * math.exp(-y * t)


@njit(cache=True, inline="always")
def hold_mode(cyclic, g, open_, times):  # pragma: no cover - compiled
    """``planting.hold_modes`` and ``planting.swing_lifts`` of one hold ``times (3,)`` at generic time ``g``: open or
    not, the turn back, and how much of the least swing lift applies."""
    heel, close = times[1] - open_, times[2] - open_
    if cyclic:
        into = (g - open_) % 1.0
        inside = into < close
        swing = 1.0 if inside or close >= 1.0 else smoothstep((1.0 - (into - close) / (1.0 - close)) / SWING_LANDING)
    else:
        into = g - open_
        inside = into >= 0.0 and (into < close or open_ + close >= 1.0 - 1e-9)
        swing = 0.0  # a one-shot verb's swings have no next landing
    if close - heel <= FLAT_TO_THE_END:  # a foot that does not roll off: flat while held
        return inside, 0.0 if inside else 1.0, swing
    return inside, smoothstep((into - heel) / (close - heel)), swing
