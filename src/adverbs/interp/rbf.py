"""Linear plus radial interpolation over adverb space (§4, eqs. 3 and 4), exact or smoothed.

For values ``b_i`` given at example points ``p_i`` (i = 1..E):

1. Linear: ``A(p) = [1, q_1, …, q_A]`` with ``q = (p − centre) / scale``. Least squares over the
   examples gives ``a = L b`` with ``L = A⁺``; the residuals ``b̃ = b − A a`` remain.
2. Radial: ``R_i(p) = B(‖q − q_i‖ / α_i)`` with ``B`` the cubic B-spline profile (support radius 2,
   ``B(0) = 2/3``, C²) and ``α_i`` the distance from ``q_i`` to its nearest other example (at most one
   range of the examples, so an isolated example does not reach across the whole space). Solve
   ``M r = b̃`` with ``M[k, i] = R_i(p_k)``.

Then ``b(p) = Σ_i r_i R_i(p) + Σ_l a_l A_l(p)``, which reproduces every example exactly, extrapolates
with the linear part, and is refined locally by the compactly supported radial part.

Because the map from values to ``b(p)`` is linear, it is also ``b(p) = Σ_i w_i(p) b_i`` with cardinal
weights ``w(p) = R(p) M⁻¹ (I − A L) + A(p) L`` (Rose, Sloan and Cohen 2001): the run-time fast path,
independent of how many values there are.

Adverb axes are measured in different units (m/s, deg/s, a mood from −1 to 1), so distances use each
axis divided by its range over the examples (``scale``); the linear part does not depend on it.

Smoothing (approximation instead of interpolation), for many takes of one motion at nearby points:

* ``smoothing = λ > 0`` solves ``(M + λI) r = b̃`` (ridge on the radial part), so
  ``w(p) = R(p) (M + λI)⁻¹ (I − A L) + A(p) L``: the examples are approached, not reproduced, and
  ``λ → ∞`` leaves the linear part alone. With ``λ > 0`` each ``α_i`` is also at least the median
  nearest-example distance (:func:`radial_scales`): the paper's α collapses between two near-duplicate
  takes into two spikes.
* ``shrinkage = μ > 0`` is ridge on the slopes of the linear part (``L = (AᵀA + μ D)⁻¹ Aᵀ``, ``D`` the
  identity but for the constant): where the adverbs explain little of how the takes differ, the
  hyperplane through a few noisy takes extrapolates their noise; ``μ → ∞`` leaves their mean.
* ``"auto"`` chooses either or both on a log grid (0 included) by leave-one-out on the values the
  weights will blend (:func:`smoothing_scores`), so exact interpolation is kept wherever it predicts
  left-out examples best.

Exact interpolation (λ = μ = 0) is the default, and wins when the examples are few, far apart and
each chosen to be reproduced (the shipped verbs, §4's setting): a take is then what the animator
wants at its point, and the adverbs are obeyed there exactly. Its cost is sensitivity: any exact
interpolant's weights go from 1 to 0 between two examples, so their gradient is at least ``1/δ`` for
two takes ``δ`` apart, and between near-duplicates the pose swings with the adverb. Smoothing wins on
clustered or noisy takes (many captures of one action): it predicts held-out takes better
(:func:`adverbs.apps.evaluate.held_out`) and bounds the sensitivity, at the price of not reproducing
the examples, and with ``μ > 0`` of obeying the adverbs less (a shrunk slope asks for less change).
In every case the weights sum to 1; with ``μ = 0`` they reproduce linear functions exactly.
"""

from __future__ import annotations

import numpy as np

from ..errors import AdverbsError

ALPHA_CAP = 1.0  # the largest radial scale α, in ranges of the examples (scaled adverb units)
ALPHA_FLOOR = 1.0  # with smoothing λ > 0, the smallest α, in median nearest-example distances
SMOOTHING_GRID = np.concatenate([[0.0], np.geomspace(1e-3, 1e3, 13)])  # the λ that "auto" chooses among
SHRINKAGE_GRID = SMOOTHING_GRID  # the μ that "auto" chooses among
ADVERB_LIMIT = 1e12  # an example's adverb value beyond ± this is a typo (and ranges of ±1e308 overflow)
AUTO_TIE = 1e-9  # "auto": scores this close to the minimum (relative to the values' variance) count as ties


def bspline_profile(r: np.ndarray) -> np.ndarray:
    """Cubic B-spline radial profile at ``r ≥ 0``: ``(4 − 6r² + 3r³)/6`` below 1, ``(2 − r)³/6`` below 2, else 0.

    Written as ``(max(2 − r, 0)³ − 4 max(1 − r, 0)³) / 6``, the same piecewise cubic without branches.
    """
    r = np.asarray(r, dtype=float)
    a = np.maximum(2.0 - r, 0.0)
    b = np.maximum(1.0 - r, 0.0)
    return (a * a * a - 4.0 * (b * b * b)) * (1.0 / 6.0)


def radial_scales(q: np.ndarray, smoothed: bool = False) -> np.ndarray:
    """Radial scales ``α (E,)`` of examples at distinct scaled points ``q (E, A)``.

    Exact interpolation: the paper's α, each example's distance to its nearest other example, capped at
    ``ALPHA_CAP``. Smoothed: also at least ``ALPHA_FLOOR`` times the median of those distances, so two
    near-duplicate takes get bases as wide as their neighbours' instead of two spikes between them.
    (Exact interpolation keeps the paper's α: with wide bases on near-duplicates, ``M`` is nearly
    singular and the exact solution's radial part grows like ``α/δ`` over the whole support.)
    """
    dist = np.linalg.norm(q[:, None] - q[None], axis=-1)
    np.fill_diagonal(dist, np.inf)
    nearest = dist.min(axis=1)
    if smoothed:
        nearest = np.maximum(nearest, ALPHA_FLOOR * np.median(nearest))
    return np.minimum(nearest, ALPHA_CAP)


def _radial(q: np.ndarray, example_q: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """``R_i(q) = B(‖q − q_i‖ / α_i)`` at scaled points ``q (..., A)``: ``(..., E)``."""
    return bspline_profile(np.linalg.norm(q[..., None, :] - example_q, axis=-1) / alpha)


def _linear_basis(q: np.ndarray) -> np.ndarray:
    """``A(q) = [1, q_1, …, q_A]``, ``(..., A+1)``."""
    return np.concatenate([np.ones(q.shape[:-1] + (1,)), q], axis=-1)


def _cardinal_tables(
    q: np.ndarray, linear: np.ndarray, smoothings: np.ndarray, shrinkages: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The weights' tables of scaled points ``q (E, A)`` for every ``λ`` in ``smoothings (G,)`` and ``μ`` in ``shrinkages (H,)``.

    Returns ``α (G, E)``, ``L (H, A+1, E)``, ``M + λI (G, E, E)`` and ``(M + λI)⁻¹ (I − A L) (G, H, E, E)``.
    ``L`` is the linear fit's map from values to coefficients: ``A⁺`` over the examples in ``linear``
    (zero columns for refinements, which get no say in the plane), ridge on the slopes when ``μ > 0``.
    """
    e, a = q.shape
    lin = _linear_basis(q)  # (E, A+1)
    fits = np.zeros((len(shrinkages), a + 1, e))
    penalty = np.eye(a + 1)
    penalty[0, 0] = 0.0  # the constant is not shrunk: the weights still sum to 1
    gram = lin[linear].T @ lin[linear]
    for h, mu in enumerate(shrinkages):
        fits[h][:, linear] = (
            np.linalg.solve(gram + mu * penalty, lin[linear].T) if mu > 0 else np.linalg.pinv(lin[linear])
        )
    projector = np.eye(e) - lin @ fits  # (H, E, E): I − A L
    smoothings = np.asarray(smoothings, dtype=float)
    alpha = np.stack([radial_scales(q, smoothed=lam > 0) for lam in smoothings])
    systems = bspline_profile(np.linalg.norm(q[:, None] - q[None], axis=-1) / alpha[:, None, :])  # M[k, i] = R_i(p_k)
    systems += smoothings[:, None, None] * np.eye(e)
    try:
        radial_from_values = np.linalg.solve(systems[:, None], projector[None])
    except np.linalg.LinAlgError:  # a singular M (exact interpolation only): least squares
        radial_from_values = np.array([[np.linalg.lstsq(m, p, rcond=None)[0] for p in projector] for m in systems])
    return alpha, fits, systems, radial_from_values


def smoothing_scores(
    points: np.ndarray,
    values: np.ndarray,
    linear: np.ndarray | None = None,
    scale: np.ndarray | None = None,
    smoothings: np.ndarray = SMOOTHING_GRID,
    shrinkages: np.ndarray = SHRINKAGE_GRID,
) -> np.ndarray:
    """Leave-one-out score of every smoothing ``λ`` and shrinkage ``μ``: ``(len(smoothings), len(shrinkages))``.

    Each example ``i`` in turn is left out, the others are fitted with that ``λ`` and ``μ`` (their own
    radial scales and linear fit; distances in the units ``scale`` of all of them, default their
    ranges) and ``values[i] (E, ...)`` is predicted at ``points[i]``. The score is the mean over
    examples of the squared error summed over the values' columns, ``mean_i ‖v_i − w₋ᵢ(p_i) V₋ᵢ‖²``,
    computed from the values' Gram matrix (so its cost does not grow with their number). Examples whose
    removal leaves fewer than two examples, or none in the linear fit, are not scored (with fewer than
    three examples every score is 0 and "auto" keeps exact interpolation).
    """
    points = np.asarray(points, dtype=float)
    e = len(points)
    values = np.asarray(values, dtype=float).reshape(e, -1)
    values = values - values.mean(axis=0)  # the weights sum to 1: the same errors, less cancellation
    gram = values @ values.T
    linear = np.ones(e, dtype=bool) if linear is None else np.asarray(linear, dtype=bool)
    q = points / (_default_scale(points, linear) if scale is None else np.asarray(scale, dtype=float))
    folds = [i for i in range(e) if e > 2 and np.delete(linear, i).any()]
    scores = np.zeros((len(smoothings), len(shrinkages)))
    for i in folds:
        rest = np.delete(np.arange(e), i)
        alpha, fits, _, radial_from_values = _cardinal_tables(q[rest], linear[rest], smoothings, shrinkages)
        radial = bspline_profile(np.linalg.norm(q[rest] - q[i], axis=-1) / alpha)  # (G, E−1)
        w = np.einsum("gk,ghkl->ghl", radial, radial_from_values) + _linear_basis(q[i]) @ fits  # (G, H, E−1)
        g = gram[np.ix_(rest, rest)]
        scores += np.einsum("ghk,kl,ghl->gh", w, g, w) - 2.0 * w @ gram[rest, i] + gram[i, i]
    return scores / max(len(folds), 1)


def _default_scale(points: np.ndarray, linear: np.ndarray) -> np.ndarray:
    """Each axis's range over the examples in the linear fit (all of them if only one), 1 where it is 0."""
    scale = np.ptp(points[linear], axis=0) if linear.sum() > 1 else np.ptp(points, axis=0)
    return np.where(scale > 0, scale, 1.0)


def _check_rule(name: str, rule: float | str) -> None:
    if isinstance(rule, str):
        if rule != "auto":
            raise AdverbsError(f"{name} must be a finite number ≥ 0 or 'auto', got {rule!r}")
    elif isinstance(rule, bool) or not isinstance(rule, int | float) or not 0 <= rule < np.inf:
        raise AdverbsError(f"{name} must be a finite number ≥ 0 or 'auto', got {rule!r}")


class AdverbInterpolator:
    """Fitted to example points; evaluates cardinal weights or interpolates values.

    Parameters
    ----------
    points : (E, A)
        Adverb points of the examples; distinct, finite.
    names : sequence of str, optional
        Example names, for error messages.
    scale : (A,), optional
        Units of each axis for distances; default: the range on that axis of the examples in ``linear``.
    linear : (E,) bool, optional
        Which examples the linear part is fitted to (default all). The others are *refinements*: they
        only enter the radial part, so moving one leaves the hyperplane alone and changes the verb
        mostly near its old and new places. Elsewhere it changes only through the radial system that
        couples overlapping supports — not at all for examples whose supports never meet it, even
        indirectly.
    smoothing : float ≥ 0 or "auto", optional
        ``λ`` of the radial system ``(M + λI) r = b̃``: 0 (default) interpolates exactly; more
        approximates, tending to the linear part alone as ``λ → ∞``; ``λ > 0`` also floors the radial
        scales (:func:`radial_scales`). "auto": chosen from ``SMOOTHING_GRID`` by leave-one-out on
        ``values``.
    shrinkage : float ≥ 0 or "auto", optional
        ``μ``, ridge on the linear part's slopes: 0 (default) is least squares; ``μ → ∞`` leaves the
        examples' mean. "auto": chosen from ``SHRINKAGE_GRID`` by leave-one-out on ``values`` (jointly
        with ``λ`` when both are "auto"). See :func:`smoothing_scores`.
    values : (E, ...), optional
        What "auto" cross-validates on: the values the weights will blend (a verb passes its control
        points and log keytime intervals, ``(E, NumCP·D + N−1)``). Needed with "auto" only.

    Attributes
    ----------
    smoothing, shrinkage : float
        ``λ`` and ``μ`` in use ("auto" resolved: pass these to rebuild the same weights without values).
    smoothing_rule, shrinkage_rule : float or "auto"
        As asked.
    smoothing_scores : (G, H) or None
        With "auto", the leave-one-out scores it chose by (:func:`smoothing_scores`; a fixed rule is a
        grid of one).
    """

    def __init__(
        self,
        points: np.ndarray,
        names: list[str] | None = None,
        scale: np.ndarray | None = None,
        linear: np.ndarray | None = None,
        smoothing: float | str = 0.0,
        shrinkage: float | str = 0.0,
        values: np.ndarray | None = None,
    ):
        points = np.asarray(points, dtype=float)
        if points.ndim != 2 or points.shape[0] < 1:
            raise AdverbsError(f"need examples as points (E, A), got shape {points.shape}")
        e, a = points.shape
        names = list(names) if names is not None else [f"example {i + 1}" for i in range(e)]
        bad = ~np.all(np.isfinite(points), axis=1)
        if bad.any():
            raise AdverbsError(f"example {names[int(np.argmax(bad))]!r} has a non-finite adverb value")
        bad = ~np.all(np.abs(points) <= ADVERB_LIMIT, axis=1)
        if bad.any():
            raise AdverbsError(
                f"example {names[int(np.argmax(bad))]!r} has an adverb value beyond ±{ADVERB_LIMIT:g}: "
                f"{points[int(np.argmax(bad))].tolist()}"
            )
        linear = np.ones(e, dtype=bool) if linear is None else np.asarray(linear, dtype=bool)
        if linear.shape != (e,) or not linear.any():
            raise AdverbsError("at least one example must take part in the linear fit")
        scale = _default_scale(points, linear) if scale is None else np.asarray(scale, dtype=float)
        self.points = points
        self.names = names
        self.linear = linear
        self.scale = scale
        self.centre = points[linear].mean(axis=0)
        q = (points - self.centre) / self.scale
        dist = np.linalg.norm(q[:, None] - q[None], axis=-1)
        np.fill_diagonal(dist, np.inf)
        i, j = np.unravel_index(np.argmin(dist), dist.shape)
        if dist[i, j] < 1e-9:
            raise AdverbsError(
                f"examples {names[i]!r} and {names[j]!r} are at the same adverb point {points[i].tolist()}; "
                "examples must be at distinct points"
            )
        _check_rule("smoothing", smoothing)
        _check_rule("shrinkage", shrinkage)
        self.smoothing_rule, self.shrinkage_rule = smoothing, shrinkage
        self.smoothing_scores = None
        if "auto" in (smoothing, shrinkage):
            if values is None or len(values) != e:
                raise AdverbsError(f"'auto' chooses by leave-one-out on the values: pass values ({e}, ...)")
            lams = SMOOTHING_GRID if smoothing == "auto" else np.array([smoothing], dtype=float)
            mus = SHRINKAGE_GRID if shrinkage == "auto" else np.array([shrinkage], dtype=float)
            self.smoothing_scores = smoothing_scores(points, values, linear, self.scale, lams, mus)
            scores = self.smoothing_scores
            # The least smoothing, then the least shrinkage, among scores equal to the minimum up to rounding.
            flat = np.asarray(values, dtype=float).reshape(e, -1)
            ties = scores <= scores.min() + AUTO_TIE * np.sum((flat - flat.mean(axis=0)) ** 2) / e
            g, h = np.unravel_index(np.argmax(ties), scores.shape)
            smoothing, shrinkage = lams[g], mus[h]
        self.smoothing, self.shrinkage = float(smoothing), float(shrinkage)
        alpha, fits, systems, radial_from_values = _cardinal_tables(q, linear, [self.smoothing], [self.shrinkage])
        self.alpha, self._lin_pinv, self._system, self._radial_from_values = (
            alpha[0],
            fits[0],
            systems[0],
            radial_from_values[0, 0],
        )
        self._q = q
        self.num_adverbs = a
        self._inv_scale = 1.0 / self.scale
        self._inv_alpha = 1.0 / self.alpha
        # [q, ‖q‖², 1] @ this = ‖q − q_i‖² / α_i² for every example i.
        inv_a2 = self._inv_alpha**2
        self._distance_form = np.vstack([-2.0 * q.T, np.ones((1, e)), np.sum(q * q, axis=-1)[None]]) * inv_a2
        self._radial_a = self._radial_from_values / 6.0
        self._radial_b = self._radial_from_values * (-4.0 / 6.0)
        self._kernel_tables = tuple(
            np.ascontiguousarray(x, dtype=float)
            for x in (self.centre, self._inv_scale, q, self._inv_alpha, self._radial_from_values, self._lin_pinv)
        )

    @property
    def kernel_tables(self) -> tuple[np.ndarray, ...]:
        """What a compiled evaluation of :meth:`weights_one` reads, in order: ``centre (A,)``, ``1 / scale (A,)``,
        the examples' scaled points ``(E, A)``, ``1 / α (E,)``, ``(M + λI)⁻¹ (I − A L) (E, E)`` and ``L (A+1, E)``
        (``M⁻¹ (I − A A⁺)`` and ``A⁺`` when exact)."""
        return self._kernel_tables

    def _normalized(self, p: np.ndarray) -> np.ndarray:
        p = np.asarray(p, dtype=float)
        if p.shape[-1:] != (self.num_adverbs,):
            raise AdverbsError(f"adverb points must be (..., {self.num_adverbs}), got {p.shape}")
        if not np.all(np.isfinite(p)):
            raise AdverbsError("adverb values must be finite numbers (got NaN or infinity)")
        return (p - self.centre) / self.scale

    def radial(self, p: np.ndarray) -> np.ndarray:
        """Radial basis values ``R_i(p)``, ``(..., E)``."""
        return _radial(self._normalized(p), self._q, self.alpha)

    def weights(self, p: np.ndarray) -> np.ndarray:
        """Cardinal weights ``w(p)``, ``(..., E)``: ``b(p) = w(p) @ values``. They sum to 1.

        Written for many points at once: ``(‖q − q_i‖ / α_i)²`` is one matrix product of augmented
        vectors, the profile is computed in place, and its constants are folded into the weight
        matrices, so each (P, E) array is passed over a few times only.
        """
        q = self._normalized(p)
        shape = q.shape[:-1]
        q = q.reshape(int(np.prod(shape)), self.num_adverbs)
        aug = np.concatenate([q, np.sum(q * q, axis=1, keepdims=True), np.ones((len(q), 1))], axis=1)
        r = aug @ self._distance_form  # (P, E): squared scaled distances
        np.maximum(r, 0.0, out=r)
        np.sqrt(r, out=r)
        # B(r) = (a³ − 4 b³) / 6 with a = max(2 − r, 0), b = max(a − 1, 0); the 1/6 and 4 live in the matrices.
        np.subtract(2.0, r, out=r)
        np.maximum(r, 0.0, out=r)
        b = r - 1.0
        np.maximum(b, 0.0, out=b)
        a3 = r * r
        a3 *= r
        b3 = b * b
        b3 *= b
        w = a3 @ self._radial_a + b3 @ self._radial_b
        w += _linear_basis(q) @ self._lin_pinv
        return w.reshape(shape + (len(self._q),))

    def linear_weights(self, p: np.ndarray) -> np.ndarray:
        """Weights ``(..., E)`` of the hyperplane alone, ``A(p) L`` (no radial part; ``L = A⁺`` unless shrunk)."""
        return _linear_basis(self._normalized(p)) @ self._lin_pinv

    def weights_one(self, p: np.ndarray) -> np.ndarray:
        """:meth:`weights` for a single point ``(A,)``: the same numbers with fewer array operations."""
        q = (p - self.centre) * self._inv_scale
        if not np.isfinite(q).all():
            raise AdverbsError("adverb values must be finite numbers (got NaN or infinity)")
        diff = self._q - q
        r = np.sqrt(np.einsum("ij,ij->i", diff, diff)) * self._inv_alpha
        a = np.maximum(2.0 - r, 0.0)
        b = np.maximum(1.0 - r, 0.0)
        radial = (a * a * a - 4.0 * (b * b * b)) * (1.0 / 6.0)
        return radial @ self._radial_from_values + (self._lin_pinv[0] + q @ self._lin_pinv[1:])

    # ----- the reference path: explicit coefficients, as in the paper ----------------------------
    def fit(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Linear coefficients ``a = L b (A+1, ...)`` and radial ``r (E, ...)`` of ``values b (E, ...)``: ``(M + λI) r = b̃``."""
        values = np.asarray(values, dtype=float)
        flat = values.reshape(values.shape[0], -1)
        a = self._lin_pinv @ flat
        residual = flat - _linear_basis(self._q) @ a
        r = np.linalg.solve(self._system, residual)
        return a.reshape((-1,) + values.shape[1:]), r.reshape(values.shape)

    def evaluate(self, p: np.ndarray, coefficients: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
        """``Σ r_i R_i(p) + Σ a_l A_l(p)`` (eq. 3) for coefficients from :meth:`fit`; ``(..., ...)``."""
        a, r = coefficients
        q = self._normalized(p)
        radial = self.radial(p)
        shape = r.shape[1:]
        out = radial @ r.reshape(r.shape[0], -1) + _linear_basis(q) @ a.reshape(a.shape[0], -1)
        return out.reshape(q.shape[:-1] + shape)


def hull_nearest_reference(points: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, float]:
    """The point of the convex hull of ``points (E, A)`` nearest ``q (A,)``, and its distance: the NumPy reference of
    the sampling kernel's Wolfe algorithm (``hull_nearest``), here a non-negative least squares on the barycentric
    weights (their sum held to 1 by a heavy row), then the nearest point of the affine hull of the examples it keeps,
    solved exactly."""
    from scipy.optimize import nnls

    points, q = np.asarray(points, dtype=float), np.asarray(q, dtype=float)
    heavy = 1e4 * max(1.0, float(np.abs(points - q).max()))
    lam, _ = nnls(np.vstack([points.T, np.full(len(points), heavy)]), np.r_[q, heavy])
    keep = np.flatnonzero(lam > 1e-12 * lam.sum())
    y = points[keep] - q
    kkt = np.block([[y @ y.T, np.ones((len(keep), 1))], [np.ones((1, len(keep))), np.zeros((1, 1))]])
    mu = np.linalg.lstsq(kkt, np.r_[np.zeros(len(keep)), 1.0], rcond=None)[0][:-1]
    if np.all(mu >= 0):
        h = mu @ points[keep]
    else:
        h = lam @ points / lam.sum()
    return h, float(np.linalg.norm(h - q))
