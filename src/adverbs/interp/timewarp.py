"""Keytime time warping between clock time ``T`` and generic time ``t`` (§3.2).

Keytimes ``K_1 = 0 < K_2 < … < K_N`` map to generic keytimes ``G_1 = 0 < G_2 < … < G_N = 1``. The paper maps
them linearly in between,

    t(T) = G_m + (G_{m+1} − G_m) (T − K_m) / (K_{m+1} − K_m)     for K_m ≤ T < K_{m+1},

whose rate dt/dT changes in a step at each keytime. Any curve fitted in generic time then changes its
velocity in clock time in one frame there: a joint's turn, and the hips over the feet of a verb that stands on
them (a bow's, 1.42 m/s² in one frame at a keytime, its capture's hips 0.58; session 60, measured). Here the rate
is continuous (the warp is C¹): at keytime ``m`` it is a mean of the rates of the two pieces it joins, weighted
towards the shorter one's (:func:`slopes`), and near it each piece's rate turns linearly between that and its own
middle rate, which is set so the piece still takes ``G_{m+1} − G_m`` in ``K_{m+1} − K_m`` (piecewise quadratic; its
inverse is closed-form). The turn takes at most :data:`RAMP` of the shorter piece, so a piece much shorter than both
its neighbours (a run's frame-long flight) keeps nearly the paper's line, and each piece's middle runs at one rate as
the paper's does. Keytime ``m`` is still generic time ``G_m`` at every point.

The paper spaces the generic keytimes evenly, ``G_m = (m − 1) / (N − 1)`` (the default here). Any
strictly increasing ``G`` shared by every example keeps what matters — keytime ``m`` is the same
generic moment in each example — and a verb spaces them as its examples' keytimes are spaced on
average (:func:`examples_spacing`), so that an interval a frame long does not get as much of the curve as
a whole step (see :mod:`adverbs.verb.fit`).

Both directions are vectorized: keytimes ``(..., N)`` broadcast against times ``(...)``.
Times before ``K_1`` or after ``K_N`` go on at the first or last keytime's rate. The first and last keytimes join
the last piece to the first (their rate is one), so a cycle's seam turns smoothly too.
"""

from __future__ import annotations

import numpy as np

from ..errors import AdverbsError
from ._warp_scalars import EXCESS, RAMP, TINY


def check_keytimes(keytimes: np.ndarray, what: str = "keytimes") -> np.ndarray:
    """Validate ``(..., N)`` keytimes: finite, N ≥ 2, strictly increasing; returns them as floats."""
    k = np.asarray(keytimes, dtype=float)
    if k.ndim < 1 or k.shape[-1] < 2:
        raise AdverbsError(f"{what}: need at least two keytimes (start and end), got {k.shape[-1] if k.ndim else 0}")
    if not np.all(np.isfinite(k)):
        raise AdverbsError(f"{what}: keytimes must be finite numbers")
    if np.any(np.diff(k, axis=-1) <= 0):
        bad = int(np.argmax(np.any(np.diff(k.reshape(-1, k.shape[-1]), axis=-1) <= 0, axis=0)))
        raise AdverbsError(
            f"{what}: keytimes must be strictly increasing (keytime {bad + 2} is not after keytime {bad + 1})"
        )
    return k


def even_spacing(n: int) -> np.ndarray:
    """The paper's generic keytimes ``(n,)``: ``(m − 1) / (n − 1)``."""
    return np.linspace(0.0, 1.0, n)


def examples_spacing(keytimes: np.ndarray) -> np.ndarray:
    """Generic keytimes ``(N,)`` spaced as the examples' keytimes ``(E, N)`` are, on average.

    Each interval is the geometric mean over the examples of its fraction of the example's duration,
    renormalized so the intervals sum to 1. The geometric mean balances the examples: an example
    whose interval is ``c`` times the generic one plays that stretch of curve ``c`` times slower, and
    the logarithms of those factors average to zero. (The arithmetic mean lets one example whose
    interval is half a frame where the others' are four play its stretch about 3x too fast: joint
    speeds 2.7x the examples' on the CMU walk with toe-offs; the shortest interval instead starves
    the longer ones of control points: fit errors doubled. Both measured.)
    """
    k = check_keytimes(np.atleast_2d(keytimes))
    r = np.exp(np.mean(np.log(np.diff(k, axis=-1) / k[:, -1:]), axis=0))
    g = np.concatenate([[0.0], np.cumsum(r / r.sum())])
    g[-1] = 1.0
    return check_generic(g, k.shape[-1])


def check_generic(generic: np.ndarray | None, n: int) -> np.ndarray:
    """Validate generic keytimes ``(n,)`` (``None``: evenly spaced): from 0 to 1, strictly increasing."""
    if generic is None:
        return even_spacing(n)
    g = np.asarray(generic, dtype=float)
    if g.shape != (n,) or not np.all(np.isfinite(g)) or g[0] != 0.0 or g[-1] != 1.0 or np.any(np.diff(g) <= 0):
        raise AdverbsError(f"generic keytimes must be {n} increasing numbers from 0 to 1, got {np.round(g, 6).tolist()}")
    return g


def slopes(keytimes: np.ndarray, generic: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """dt/dT at each keytime ``(..., N)`` and the seconds over which the rate turns to it on either side ``(..., N)``.

    A keytime's rate is the mean of its two pieces' rates, each weighted by the other's length, so the shorter piece's
    counts the more: a piece much shorter than both its neighbours (a run's frame-long flight) keeps nearly the
    paper's line. (The shorter piece's rate alone jumps where two pieces pass each other in length: a walk's two
    steps, equal to a rounding, played at an example point 3 mm off the example.) The rate turns over :data:`RAMP`
    of the shorter piece, no longer than either piece at that rate would take for :data:`RAMP` of its own generic
    stretch (so every piece's middle rate stays at least three quarters of its own), and no longer than puts
    :data:`EXCESS` of either piece's generic stretch off its own rate: where a piece half a frame long meets one
    twelve frames long (toe-offs as keytimes, evenly spaced), a quarter of the short one's length at nearly its rate
    took an eighth of the long one's stretch within a frame, and the fit strayed between frames at 2.5x the
    examples' speed (the CMU walk; 1.44x under the paper's warp). The first and last keytimes join the last and
    first pieces, so a cycle's warp turns its seam smoothly too."""
    h = np.diff(keytimes, axis=-1)
    gap = np.broadcast_to(np.diff(generic), h.shape)
    hs = np.concatenate([h[..., -1:], h], axis=-1), np.concatenate([h, h[..., :1]], axis=-1)
    gs = np.concatenate([gap[..., -1:], gap], axis=-1), np.concatenate([gap, gap[..., :1]], axis=-1)
    d = (gs[0] * hs[1] / hs[0] + gs[1] * hs[0] / hs[1]) / (hs[0] + hs[1])
    e = RAMP * np.minimum(np.minimum(hs[0], hs[1]), np.minimum(gs[0], gs[1]) / d)
    off = [EXCESS * g / np.maximum(np.abs(d - g / h), TINY) for g, h in zip(gs, hs)]
    return d, np.minimum(np.minimum(e, off[0]), off[1])


def _piece(keytimes: np.ndarray, g: np.ndarray, m: np.ndarray):
    """Piece ``m``'s keytimes, generic keytimes, ramps and rates (at its keytimes, in its middle), broadcast to ``m``:
    its rate turns linearly from its first keytime's to its own over that keytime's ramp and back to its last
    keytime's over the last's, its middle rate such that it covers its generic stretch in its time."""
    n = keytimes.shape[-1]
    k = np.broadcast_to(keytimes, m.shape + (n,))
    d, e = (np.broadcast_to(x, m.shape + (n,)) for x in slopes(keytimes, g))

    def at(a, j):
        return np.take_along_axis(a, (m + j)[..., None], -1)[..., 0]

    k0, k1, d0, d1, e0, e1 = at(k, 0), at(k, 1), at(d, 0), at(d, 1), at(e, 0), at(e, 1)
    c = (g[m + 1] - g[m] - 0.5 * (e0 * d0 + e1 * d1)) / (k1 - k0 - 0.5 * (e0 + e1))
    return k0, k1, g[m], g[m + 1], e0, e1, d0, d1, c


def _root(d, c, e, x):
    """The ``s ≥ 0`` of ``s (d + (c − d) s / 2e) = x``: how long a ramp from rate ``d`` to ``c`` takes to cover
    ``x``."""
    return 2.0 * x / (d + np.sqrt(np.maximum(d * d + 2.0 * (c - d) * x / e, 0.0)))


def _segment(x: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Index m of the piece ``edges[m] ≤ x < edges[m+1]``, clipped to the first and last piece."""
    n = edges.shape[-1]
    m = np.sum(edges[..., 1:-1] <= x[..., None], axis=-1)
    return np.clip(m, 0, n - 2)


def generic_time(clock: np.ndarray, keytimes: np.ndarray, generic: np.ndarray | None = None) -> np.ndarray:
    """Generic time ``t (...)`` of clock times ``T (...)`` under keytimes ``(..., N)`` and generic keytimes ``(N,)``."""
    clock = np.asarray(clock, dtype=float)
    keytimes = np.asarray(keytimes, dtype=float)
    g = check_generic(generic, keytimes.shape[-1])
    k0, k1, g0, g1, e0, e1, d0, d1, c = _piece(keytimes, g, _segment(clock, keytimes))
    s, u = clock - k0, k1 - clock
    t = np.where(s < e0, g0 + s * (d0 + 0.5 * (c - d0) * s / e0), g0 + 0.5 * e0 * (d0 + c) + c * (s - e0))
    t = np.where(u < e1, g1 - u * (d1 + 0.5 * (c - d1) * u / e1), t)
    return np.where(s <= 0.0, g0 + d0 * s, np.where(u <= 0.0, g1 - d1 * u, t))


def clock_time(generic_times: np.ndarray, keytimes: np.ndarray, generic: np.ndarray | None = None) -> np.ndarray:
    """Clock time ``T (...)`` of generic times ``t (...)``: the inverse of :func:`generic_time`."""
    t = np.asarray(generic_times, dtype=float)
    keytimes = np.asarray(keytimes, dtype=float)
    g = check_generic(generic, keytimes.shape[-1])
    k0, k1, g0, g1, e0, e1, d0, d1, c = _piece(keytimes, g, _segment(t, g))
    a, b = g0 + 0.5 * e0 * (d0 + c), g1 - 0.5 * e1 * (d1 + c)
    with np.errstate(invalid="ignore", divide="ignore"):
        clock = np.where(t < a, k0 + _root(d0, c, e0, t - g0), k0 + e0 + (t - a) / c)
        clock = np.where(t > b, k1 - _root(d1, c, e1, g1 - t), clock)
    return np.where(t <= g0, k0 + (t - g0) / d0, np.where(t >= g1, k1 + (t - g1) / d1, clock))
