"""Keytime time warping between clock time ``T`` and generic time ``t`` (§3.2).

Keytimes ``K_1 = 0 < K_2 < … < K_N`` map to ``t = (m − 1) / (N − 1)``, linearly in between:

    t(T) = ((m − 1) + (T − K_m) / (K_{m+1} − K_m)) / (N − 1)     for K_m ≤ T < K_{m+1}

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


def _segment(x: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Index m of the piece ``edges[m] ≤ x < edges[m+1]``, clipped to the first and last piece."""
    n = edges.shape[-1]
    m = np.sum(edges[..., 1:-1] <= x[..., None], axis=-1)
    return np.clip(m, 0, n - 2)


def generic_time(clock: np.ndarray, keytimes: np.ndarray) -> np.ndarray:
    """Generic time ``t (...)`` of clock times ``T (...)`` under keytimes ``(..., N)``."""
    clock = np.asarray(clock, dtype=float)
    keytimes = np.asarray(keytimes, dtype=float)
    n = keytimes.shape[-1]
    m = _segment(clock, keytimes)
    k0 = np.take_along_axis(np.broadcast_to(keytimes, m.shape + (n,)), m[..., None], -1)[..., 0]
    k1 = np.take_along_axis(np.broadcast_to(keytimes, m.shape + (n,)), m[..., None] + 1, -1)[..., 0]
    return (m + (clock - k0) / (k1 - k0)) / (n - 1)


def clock_time(generic: np.ndarray, keytimes: np.ndarray) -> np.ndarray:
    """Clock time ``T (...)`` of generic times ``t (...)``: the inverse of :func:`generic_time`."""
    generic = np.asarray(generic, dtype=float)
    keytimes = np.asarray(keytimes, dtype=float)
    n = keytimes.shape[-1]
    x = generic * (n - 1)
    m = np.clip(np.floor(x).astype(np.int64), 0, n - 2)
    k0 = np.take_along_axis(np.broadcast_to(keytimes, m.shape + (n,)), m[..., None], -1)[..., 0]
    k1 = np.take_along_axis(np.broadcast_to(keytimes, m.shape + (n,)), m[..., None] + 1, -1)[..., 0]
    return k0 + (x - m) * (k1 - k0)
