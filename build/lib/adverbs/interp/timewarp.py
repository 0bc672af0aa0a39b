"""Keytime time warping between clock time ``T`` and generic time ``t`` (§3.2).

Keytimes ``K_1 = 0 < K_2 < … < K_N`` map to generic keytimes ``G_1 = 0 < G_2 < … < G_N = 1``, linearly
in between:

    t(T) = G_m + (G_{m+1} − G_m) (T − K_m) / (K_{m+1} − K_m)     for K_m ≤ T < K_{m+1}

The paper spaces the generic keytimes evenly, ``G_m = (m − 1) / (N − 1)`` (the default here). Any
strictly increasing ``G`` shared by every example keeps what matters — keytime ``m`` is the same
generic moment in each example — and a verb spaces them as its examples' keytimes are spaced on
average (:func:`examples_spacing`), so that an interval a frame long does not get as much of the curve as
a whole step (see :mod:`adverbs.verb.fit`).

Both directions are vectorized: keytimes ``(..., N)`` broadcast against times ``(...)``.
Times before ``K_1`` or after ``K_N`` extend the first or last piece linearly.
"""

from __future__ import annotations

import numpy as np

from ..errors import AdverbsError


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


def _segment(x: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Index m of the piece ``edges[m] ≤ x < edges[m+1]``, clipped to the first and last piece."""
    n = edges.shape[-1]
    m = np.sum(edges[..., 1:-1] <= x[..., None], axis=-1)
    return np.clip(m, 0, n - 2)


def generic_time(clock: np.ndarray, keytimes: np.ndarray, generic: np.ndarray | None = None) -> np.ndarray:
    """Generic time ``t (...)`` of clock times ``T (...)`` under keytimes ``(..., N)`` and generic keytimes ``(N,)``."""
    clock = np.asarray(clock, dtype=float)
    keytimes = np.asarray(keytimes, dtype=float)
    n = keytimes.shape[-1]
    g = check_generic(generic, n)
    m = _segment(clock, keytimes)
    k0 = np.take_along_axis(np.broadcast_to(keytimes, m.shape + (n,)), m[..., None], -1)[..., 0]
    k1 = np.take_along_axis(np.broadcast_to(keytimes, m.shape + (n,)), m[..., None] + 1, -1)[..., 0]
    return g[m] + (g[m + 1] - g[m]) * (clock - k0) / (k1 - k0)


def clock_time(generic_times: np.ndarray, keytimes: np.ndarray, generic: np.ndarray | None = None) -> np.ndarray:
    """Clock time ``T (...)`` of generic times ``t (...)``: the inverse of :func:`generic_time`."""
    t = np.asarray(generic_times, dtype=float)
    keytimes = np.asarray(keytimes, dtype=float)
    n = keytimes.shape[-1]
    g = check_generic(generic, n)
    m = _segment(t, g)
    k0 = np.take_along_axis(np.broadcast_to(keytimes, m.shape + (n,)), m[..., None], -1)[..., 0]
    k1 = np.take_along_axis(np.broadcast_to(keytimes, m.shape + (n,)), m[..., None] + 1, -1)[..., 0]
    return k0 + (t - g[m]) / (g[m + 1] - g[m]) * (k1 - k0)
