"""Uniform cubic B-splines over generic time ``t ∈ [0, 1]`` (§3.1).

Every example of a verb shares one knot vector, so control point ``k`` means the same structural
moment in each. ``n ≥ 4`` control points on uniform knots that run past both ends of ``[0, 1]``:
``u = t (n − 3)``, so every segment has the same shape and at any ``t`` exactly four control points
are live; :func:`basis` returns their indices and weights, which is all evaluation needs.

Cycles (walks) are fitted the same way: a captured cycle does not end exactly where it began, and
the seam is blended where cycles are played one after another (see ``Verb.synthesize``).
"""

from __future__ import annotations

import numpy as np

from ..errors import AdverbsError


def check_num_cp(num_cp: int) -> None:
    if int(num_cp) != num_cp or num_cp < 4:
        raise AdverbsError(f"NumCP must be a whole number of at least 4, got {num_cp}")


def basis(t: np.ndarray, num_cp: int) -> tuple[np.ndarray, np.ndarray]:
    """Live control points ``(..., 4)`` int and their weights ``(..., 4)`` at generic times ``t (...)``.

    ``t`` outside ``[0, 1]`` is clamped.
    """
    t = np.asarray(t, dtype=float)
    u = np.clip(t, 0.0, 1.0) * (num_cp - 3)
    seg = np.minimum(np.floor(u), num_cp - 4)
    x = u - seg
    x2 = x * x
    x3 = x2 * x
    w = np.stack([(1.0 - x) ** 3, 3.0 * x3 - 6.0 * x2 + 4.0, -3.0 * x3 + 3.0 * x2 + 3.0 * x + 1.0, x3], axis=-1) * (
        1.0 / 6.0
    )
    return seg.astype(np.int64)[..., None] + np.arange(4), w


def design_matrix(t: np.ndarray, num_cp: int) -> np.ndarray:
    """``(S, num_cp)`` matrix ``B`` with ``curve(t_s) = B[s] @ coefficients``."""
    idx, w = basis(np.asarray(t, dtype=float).reshape(-1), num_cp)
    b = np.zeros((len(idx), num_cp))
    np.add.at(b, (np.arange(len(idx))[:, None], idx), w)
    return b


def fit(t: np.ndarray, values: np.ndarray, num_cp: int, smoothing: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Regularized least-squares control points ``(num_cp, D)`` for samples ``values (S, D)`` at generic times ``t (S,)``.

    Minimizes ``‖B c − v‖² + λ ‖Δ² c‖²`` with ``Δ²`` the second differences of the control points and
    ``λ = smoothing · tr(BᵀB) / num_cp``: a penalty that vanishes on straight lines (so they are fitted
    exactly) and keeps the system well posed where a stretch of generic time holds few samples
    (keytimes a frame apart), instead of letting unobserved control points swing between samples.
    ``smoothing = 0`` is plain least squares. Returns the control points and the residuals ``(S, D)``.
    """
    if len(t) < num_cp:
        raise AdverbsError(f"{len(t)} samples cannot determine {num_cp} control points; lower NumCP")
    if not (np.isfinite(smoothing) and smoothing >= 0):
        raise AdverbsError(f"smoothing must be a number ≥ 0, got {smoothing}")
    b = design_matrix(t, num_cp)
    if smoothing == 0:
        coef, *_ = np.linalg.lstsq(b, values, rcond=None)
    else:
        coef = np.linalg.solve(normal_matrix(b, smoothing), b.T @ values)
    return coef, values - b @ coef


def normal_matrix(b: np.ndarray, smoothing: float) -> np.ndarray:
    """``BᵀB + λ Δ²ᵀΔ²`` with ``λ = smoothing · tr(BᵀB) / num_cp``: the system :func:`fit` solves."""
    btb = b.T @ b
    n = b.shape[1]
    d2 = np.diff(np.eye(n), n=2, axis=0)
    return btb + smoothing * np.trace(btb) / n * (d2.T @ d2)


def evaluate(coefficients: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Curve values ``(..., D)`` at ``t (...)`` from control points ``(num_cp, D)``."""
    idx, w = basis(t, coefficients.shape[0])
    return np.einsum("...k,...kd->...d", w, coefficients[idx])


def ends(coefficients: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Value and slope ``d/dt`` at ``t = 0`` and ``t = 1``, each ``(D,)``."""
    c = coefficients
    scale = c.shape[0] - 3
    v0 = (c[0] + 4.0 * c[1] + c[2]) / 6.0
    v1 = (c[-3] + 4.0 * c[-2] + c[-1]) / 6.0
    s0 = 0.5 * (c[2] - c[0]) * scale
    s1 = 0.5 * (c[-1] - c[-3]) * scale
    return v0, s0, v1, s1
