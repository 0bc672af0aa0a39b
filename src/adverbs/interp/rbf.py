"""Linear plus radial interpolation over adverb space (§4, eqs. 3 and 4).

For values ``b_i`` given at example points ``p_i`` (i = 1..E):

1. Linear: ``A(p) = [1, q_1, …, q_A]`` with ``q = (p − centre) / scale``. Least squares over the
   examples gives ``a = A⁺ b``; the residuals ``b̃ = b − A a`` remain.
2. Radial: ``R_i(p) = B(‖q − q_i‖ / α_i)`` with ``B`` the cubic B-spline profile (support radius 2,
   ``B(0) = 2/3``, C²) and ``α_i`` the distance from ``q_i`` to its nearest other example (at most one
   range of the examples, so an isolated example does not reach across the whole space). Solve
   ``M r = b̃`` with ``M[k, i] = R_i(p_k)``.

Then ``b(p) = Σ_i r_i R_i(p) + Σ_l a_l A_l(p)``, which reproduces every example exactly, extrapolates
with the linear part, and is refined locally by the compactly supported radial part.

Because the map from values to ``b(p)`` is linear, it is also ``b(p) = Σ_i w_i(p) b_i`` with cardinal
weights ``w(p) = R(p) M⁻¹ (I − A A⁺) + A(p) A⁺`` (Rose, Sloan and Cohen 2001): the run-time fast path,
independent of how many values there are.

Adverb axes are measured in different units (m/s, deg/s, a mood from −1 to 1), so distances use each
axis divided by its range over the examples (``scale``); the linear part does not depend on it.
"""

from __future__ import annotations

import numpy as np

from ..errors import AdverbsError

ALPHA_CAP = 1.0  # the largest radial scale α, in ranges of the examples (scaled adverb units)


def bspline_profile(r: np.ndarray) -> np.ndarray:
    """Cubic B-spline radial profile at ``r ≥ 0``: ``(4 − 6r² + 3r³)/6`` below 1, ``(2 − r)³/6`` below 2, else 0.

    Written as ``(max(2 − r, 0)³ − 4 max(1 − r, 0)³) / 6``, the same piecewise cubic without branches.
    """
    r = np.asarray(r, dtype=float)
    a = np.maximum(2.0 - r, 0.0)
    b = np.maximum(1.0 - r, 0.0)
    return (a * a * a - 4.0 * (b * b * b)) * (1.0 / 6.0)


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
    """

    def __init__(
        self,
        points: np.ndarray,
        names: list[str] | None = None,
        scale: np.ndarray | None = None,
        linear: np.ndarray | None = None,
    ):
        points = np.asarray(points, dtype=float)
        if points.ndim != 2 or points.shape[0] < 2:
            raise AdverbsError(f"need at least two examples as points (E, A), got shape {points.shape}")
        e, a = points.shape
        names = list(names) if names is not None else [f"example {i + 1}" for i in range(e)]
        bad = ~np.all(np.isfinite(points), axis=1)
        if bad.any():
            raise AdverbsError(f"example {names[int(np.argmax(bad))]!r} has a non-finite adverb value")
        linear = np.ones(e, dtype=bool) if linear is None else np.asarray(linear, dtype=bool)
        if linear.shape != (e,) or not linear.any():
            raise AdverbsError("at least one example must take part in the linear fit")
        if scale is None:
            scale = np.ptp(points[linear], axis=0) if linear.sum() > 1 else np.ptp(points, axis=0)
            scale = np.where(scale > 0, scale, 1.0)
        self.points = points
        self.names = names
        self.linear = linear
        self.scale = np.asarray(scale, dtype=float)
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
        # The paper's α: distance to the nearest other example. Capped at one range of the examples so
        # that an outlier's basis stays local instead of growing with its isolation.
        self.alpha = np.minimum(dist.min(axis=1), ALPHA_CAP)  # (E,)
        self._q = q
        lin = self._linear_basis(q)  # (E, A+1)
        self._lin_pinv = np.zeros((a + 1, e))  # (A+1, E): refinements get no say in the plane
        self._lin_pinv[:, linear] = np.linalg.pinv(lin[linear])
        m = bspline_profile(np.linalg.norm(q[:, None] - q[None], axis=-1) / self.alpha[None, :])  # M[k, i] = R_i(p_k)
        self._m = m
        self._projector = np.eye(e) - lin @ self._lin_pinv  # I − A A⁺
        try:
            self._radial_from_values = np.linalg.solve(m, self._projector)  # M⁻¹ (I − A A⁺), (E, E)
        except np.linalg.LinAlgError:
            self._radial_from_values = np.linalg.lstsq(m, self._projector, rcond=None)[0]
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
        the examples' scaled points ``(E, A)``, ``1 / α (E,)``, ``M⁻¹ (I − A A⁺) (E, E)`` and ``A⁺ (A+1, E)``."""
        return self._kernel_tables

    @staticmethod
    def _linear_basis(q: np.ndarray) -> np.ndarray:
        return np.concatenate([np.ones(q.shape[:-1] + (1,)), q], axis=-1)

    def _normalized(self, p: np.ndarray) -> np.ndarray:
        p = np.asarray(p, dtype=float)
        if p.shape[-1:] != (self.num_adverbs,):
            raise AdverbsError(f"adverb points must be (..., {self.num_adverbs}), got {p.shape}")
        if not np.all(np.isfinite(p)):
            raise AdverbsError("adverb values must be finite numbers (got NaN or infinity)")
        return (p - self.centre) / self.scale

    def radial(self, p: np.ndarray) -> np.ndarray:
        """Radial basis values ``R_i(p)``, ``(..., E)``."""
        q = self._normalized(p)
        d = np.sqrt(np.sum((q[..., None, :] - self._q) ** 2, axis=-1))
        return bspline_profile(d / self.alpha)

    def weights(self, p: np.ndarray) -> np.ndarray:
        """Cardinal weights ``w(p)``, ``(..., E)``: ``b(p) = w(p) @ values``. They sum to 1.

        Written for many points at once: ``(‖q − q_i‖ / α_i)²`` is one matrix product of augmented
        vectors, the profile is computed in place, and its constants are folded into the weight
        matrices, so each (P, E) array is passed over a few times only.
        """
        q = self._normalized(p)
        shape = q.shape[:-1]
        q = q.reshape(-1, self.num_adverbs)
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
        w += self._linear_basis(q) @ self._lin_pinv
        return w.reshape(shape + (len(self._q),))

    def linear_weights(self, p: np.ndarray) -> np.ndarray:
        """Weights ``(..., E)`` of the least-squares hyperplane alone, ``A(p) A⁺`` (no radial part)."""
        return self._linear_basis(self._normalized(p)) @ self._lin_pinv

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
        """Linear coefficients ``a (A+1, ...)`` and radial coefficients ``r (E, ...)`` of ``values (E, ...)``."""
        values = np.asarray(values, dtype=float)
        flat = values.reshape(values.shape[0], -1)
        a = self._lin_pinv @ flat
        residual = flat - self._linear_basis(self._q) @ a
        r = np.linalg.solve(self._m, residual)
        return a.reshape((-1,) + values.shape[1:]), r.reshape(values.shape)

    def evaluate(self, p: np.ndarray, coefficients: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
        """``Σ r_i R_i(p) + Σ a_l A_l(p)`` (eq. 3) for coefficients from :meth:`fit`; ``(..., ...)``."""
        a, r = coefficients
        q = self._normalized(p)
        radial = self.radial(p)
        shape = r.shape[1:]
        out = radial @ r.reshape(r.shape[0], -1) + self._linear_basis(q) @ a.reshape(a.shape[0], -1)
        return out.reshape(q.shape[:-1] + shape)
