"""Sampling a verb for C creatures at once: the one evaluation path (§3.2, §4, eq. 3).

Every evaluation of a verb — one pose, a crowd frame, a whole synthesized clip — goes through
:func:`sample`: adverb points ``(C, A)``, clock times ``(C,)`` and a :class:`SamplingState` the
caller owns → DOFs ``(C, D)``. One creature is ``C = 1``. For each creature:

1. weights ``w(p)`` and keytimes ``K(p)`` (cached in the state; recomputed only for creatures whose
   adverb point changed);
2. the clock ``T`` is split into a cycle ``n`` and a time within it, ``T − n K_N`` (cyclic verbs; a
   time exactly at a cycle's end belongs to that cycle, times before 0 are held at 0) or clamped to
   ``[0, K_N]`` (one-shot verbs);
3. generic time ``t = GenericTime(T, K(p))`` (§3.2, keytime ``m`` at the verb's generic keytime ``G_m``) and the four B-spline control points live at
   ``t``, each interpolated as ``Σ_i w_i c_i`` (eq. 3);
4. from the second cycle on, the jump ``δ = d(1) − d(0)`` where a captured cycle does not end where it
   began is added and faded out over the first quarter of the cycle (smoothstep; for the root's
   velocities a fade that integrates to zero, so the blend adds no distance or turn), so the motion is
   continuous from cycle to cycle;
5. a verb with a goal (:mod:`.goal`) adds each creature's offset on its goal chain, solved when its adverb
   point changes, weighted by the goal's smoothstep window in generic time.

Steps 2–4 are a compiled loop (:mod:`._sampling_kernel`); :func:`sample_reference` is the same
mathematics written out with explicit coefficients (eq. 3), the time warp and the spline, as the
readable reference a test holds it to.

The root is not integrated here: :func:`advance` moves each creature's root on by ``dt`` from the
velocities in its DOFs, a separate step, so a run-time loop can blend verbs before integrating.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..compiled import one_blas_thread
from ..errors import AdverbsError
from ..interp import bspline, timewarp
from ..interp.rbf import hull_nearest_reference
from . import goal as goals
from ._sampling_kernel import (
    CYCLE_EPS, CYCLIC, GENERIC, GROUPED, HULL_TOL, ONE_SHOT, VELOCITIES, pose_one, refresh_batch, sample_batch,
)  # fmt: skip

if TYPE_CHECKING:
    from .tables import Verb

SEAM_BLEND = 0.25  # fraction of a cycle over which the seam between cycles is faded out
CHUNK = 2048  # queries per block when many adverb points are new at once (weights stay in cache)
SHORTEST_CYCLE = 0.05  # seconds: a cycle (or one-shot motion) shorter than this has degenerated
LONGEST_CYCLE = 60.0  # seconds: a cycle (or one-shot motion) longer than this has degenerated
MAX_GAIN = 1e6  # sum of the blend weights' magnitudes (1 within the examples): past this a motion has degenerated


def degenerate(verb: Verb, point: np.ndarray | None, why: str) -> AdverbsError:
    """The error for an adverb ``point`` so far outside the examples that the motion degenerates, ``why`` in brackets."""
    at = "" if point is None else " at " + ", ".join(f"{n}={v:g}" for n, v in zip(verb.adverb_names, point))
    lo, hi = verb.points.min(axis=0), verb.points.max(axis=0)
    ranges = ", ".join(f"{n} {a:g} .. {b:g}" for n, a, b in zip(verb.adverb_names, lo, hi))
    return AdverbsError(
        f"verb {verb.name!r}{at}: the motion degenerates there ({why}). The examples span {ranges}: "
        "ask for adverbs nearer them (adverbs synth --clamp keeps them inside)"
    )


@dataclass(eq=False)
class SamplingState:
    """What C creatures playing one verb remember between samples; owned by the caller, never by the verb.

    Attributes
    ----------
    points : (C, A)
        The adverb point of each creature that the cached rows belong to.
    cached : (C,) bool
        Which rows hold a computed cache (False until a creature is first sampled).
    weights : (C, E) or (C, 2E)
        Cardinal weights ``w(p)`` at ``points``; for a verb that holds DOFs past its examples, then ``w(h) − w(p)``,
        ``h`` the point of the examples' hull nearest (zeros inside it: see ``Verb.follows``).
    keytimes : (C, N)
        Keytimes ``K(p)``, seconds.
    seam : (C, D)
        The seam jump ``d(1) − d(0)`` at ``points`` (cyclic verbs; zero for one-shot ones).
    goal : (C, K)
        The offset on the verb's goal chain (its ``goal.columns``) at ``points``; ``K = 0`` without a goal.
    cycle : (C,) int
        The cycle each creature was in at its last sample (0 for the first).
    root : (C, 3)
        ``(x, z, heading)`` of each creature's body root, moved on by :func:`advance`.
    verb : Verb
        The verb whose tables the cached rows come from (a state serves one verb).
    """

    points: np.ndarray
    cached: np.ndarray
    weights: np.ndarray
    keytimes: np.ndarray
    seam: np.ndarray
    goal: np.ndarray
    cycle: np.ndarray
    root: np.ndarray
    verb: Verb

    @classmethod
    def new(cls, verb: Verb, creatures: int = 1, root: np.ndarray | None = None) -> SamplingState:
        """An empty state for ``creatures`` creatures of ``verb``, their roots at ``root (C, 3)`` (default: the origin, facing +Z)."""
        if isinstance(creatures, bool) or not isinstance(creatures, int | np.integer) or creatures < 1:
            raise AdverbsError(f"creatures must be a whole number ≥ 1, got {creatures!r}")
        c = int(creatures)
        e, a = verb.weight_columns, verb.points.shape[1]
        if root is None:
            start = np.zeros((c, 3))
        else:
            start = np.array(np.broadcast_to(np.asarray(root, dtype=float), (c, 3)))
            if not np.all(np.isfinite(start)):
                raise AdverbsError("root must be finite (x, z, heading) numbers")
        return cls(
            np.full((c, a), np.nan),
            np.zeros(c, dtype=bool),
            np.zeros((c, e)),
            np.tile(verb.keytimes_table[0], (c, 1)),
            np.zeros((c, verb.num_dofs)),
            np.zeros((c, 0 if verb.goal is None else len(verb.goal.columns))),
            np.zeros(c, dtype=np.int64),
            start,
            verb,
        )

    @property
    def creatures(self) -> int:
        return len(self.points)

    def check(self, verb: Verb, creatures: int) -> None:
        """Raise an error unless this state serves ``verb`` for ``creatures`` creatures."""
        if self.verb is not verb:
            raise AdverbsError(
                f"this sampling state belongs to verb {self.verb.name!r}, not {verb.name!r}: make one with verb.state()"
            )
        if len(self.points) != creatures:
            raise AdverbsError(f"sampling state holds {len(self.points)} creatures, got {creatures} adverb points")

    def update(self, verb: Verb, points: np.ndarray) -> bool:
        """Recompute the cached rows of creatures whose adverb point differs from ``points (C, A)``; whether any did."""
        if len(points) == 1:  # one creature: a byte comparison is the cheapest test
            if self.cached[0] and points.tobytes() == self.points.tobytes():
                return False
            changed = np.zeros(1, dtype=np.int64)
        else:
            changed = np.flatnonzero(~self.cached | np.any(points != self.points, axis=1))
            if len(changed) == 0:
                return False
        p = np.ascontiguousarray(points[changed], dtype=float).reshape(len(changed), self.points.shape[1])
        if not np.all(np.isfinite(p)):
            bad = verb.adverb_names[int(np.flatnonzero(~np.isfinite(p).all(axis=0))[0])]
            raise AdverbsError(f"adverb {bad!r} must be a finite number (got NaN or infinity)")
        old, was = self.points[changed], self.cached[changed]
        self.points[changed] = p
        self._refresh(verb, changed)
        try:
            _check_degenerate(verb, p, self.weights, self.keytimes, changed)
        except AdverbsError:  # a refused point changes nothing: the rows go back to what they were
            self.points[changed], self.cached[changed] = old, was
            self._refresh(verb, changed[was])
            raise
        self.cached[changed] = True
        if verb.goal is not None:
            self.goal[changed] = goals.solve(verb, verb.goal, self.weights[changed], self.keytimes[changed], p)
        return True

    def _refresh(self, verb: Verb, rows: np.ndarray) -> None:
        """Weights, keytimes and seam of the creatures ``rows`` at their ``points``."""
        d = verb.num_dofs if verb.cyclic else 0  # a one-shot verb has no seam to hide
        refresh_batch(
            self.points, rows, *verb.interpolator.kernel_tables, verb.log_intervals, verb.interval_bounds,
            verb.seam_table[:, :d], self.weights, self.keytimes, self.seam[:, :d],
        )  # fmt: skip


def _check_degenerate(verb: Verb, points: np.ndarray, weights: np.ndarray, keytimes: np.ndarray, rows: np.ndarray) -> None:
    """Refuse adverb ``points (n, A)`` of the creatures ``rows (n,)`` so far outside the examples that their blend
    ``weights (C, E)`` amplify the examples' differences past ``MAX_GAIN`` times, or their motion (``keytimes
    (C, N)``) lasts outside ``SHORTEST_CYCLE`` .. ``LONGEST_CYCLE``: frame after frame such a motion is no motion
    (a cycle of 0 s divides by zero), and synthesis refuses it before any work."""
    if len(rows) == 1:  # one creature (a pose): plain numbers
        r = int(rows[0])
        g, n = float(np.abs(weights[r]).sum()), float(keytimes[r, -1])
        if g <= MAX_GAIN and SHORTEST_CYCLE <= n <= LONGEST_CYCLE:
            return
        gain, length = np.array([g]), np.array([n])
    else:
        gain = np.abs(weights[rows]).sum(axis=1)  # how many times over the examples' differences are blended
        length = keytimes[rows, -1]
    bad = ~(gain <= MAX_GAIN) | ~((length >= SHORTEST_CYCLE) & (length <= LONGEST_CYCLE))
    if not bad.any():
        return
    i = int(np.argmax(bad))
    if not gain[i] <= MAX_GAIN:  # keytimes clamped to the examples' (Verb.timing) cannot show a runaway point
        raise degenerate(verb, points[i], f"its blend weights the examples {gain[i]:.3g} times over; at most {MAX_GAIN:g}")
    what = "cycle" if verb.cyclic else "motion"
    raise degenerate(
        verb, points[i], f"one {what} would last {length[i]:.3g} s; it must last from {SHORTEST_CYCLE:g} s to {LONGEST_CYCLE:g} s"
    )


def mode(verb: Verb) -> int:
    """What the kernel makes of clock times for ``verb``: cycles or one motion."""
    return CYCLIC if verb.cyclic else ONE_SHOT


def run_kernel(
    verb: Verb,
    state: SamplingState,
    rows: np.ndarray,
    times: np.ndarray,
    kind: int,
    cycles: np.ndarray | None = None,
) -> np.ndarray:
    """DOFs ``(Q, D)`` of ``verb`` from the compiled kernel for the creatures ``rows (Q,)`` of an up-to-date
    ``state`` at ``times (Q,)`` (see :mod:`._sampling_kernel`: ``kind`` says what the times are).

    Each query's cycle index is written into ``cycles (Q,)`` when it is given.
    """
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    out = np.empty((len(rows), verb.num_dofs))
    cycles = np.empty(len(rows), dtype=np.int64) if cycles is None else cycles
    g = verb.goal
    columns, window = (_NO_COLUMNS, _NO_WINDOW) if g is None else (g.columns, g.window)
    args = (
        verb.segments, state.weights, state.keytimes, verb.generic_keytimes, state.seam, state.goal, columns, window,
        rows, np.ascontiguousarray(times, dtype=float), kind, SEAM_BLEND, out, cycles,
    )  # fmt: skip
    if len(rows) < GROUPED:  # one by one, no BLAS
        sample_batch(*args)
    else:
        with one_blas_thread():
            sample_batch(*args)
    return out


_NO_COLUMNS = np.zeros(0, dtype=np.int64)
_NO_WINDOW = np.zeros(3)


def _sample_state(verb: Verb, points: np.ndarray, clocks: np.ndarray, state: SamplingState | None) -> tuple[np.ndarray, SamplingState]:
    """What :func:`sample` and :func:`pose` share once their arguments are checked: points ``(C, A)``, clocks ``(C,)``."""
    if state is None:
        state = SamplingState.new(verb, len(points))
    state.check(verb, len(points))
    state.update(verb, points)
    return run_kernel(verb, state, np.arange(len(points)), clocks, mode(verb), state.cycle), state


def sample(
    verb: Verb, points: np.ndarray, clocks: np.ndarray, state: SamplingState | None = None
) -> tuple[np.ndarray, SamplingState]:
    """DOFs ``(C, D)`` of C creatures at adverb points ``points (C, A)`` and clock times ``clocks (C,)``.

    ``clocks`` are seconds since each creature's instance of the verb began. ``state`` (one from
    ``verb.state(C)``) caches what depends on each creature's adverb point; it is updated in place
    (cached rows, ``cycle``) and returned. Without one, a fresh state is made (and nothing is
    cached between calls).
    """
    p = np.asarray(points, dtype=float)
    a = len(verb.adverbs)
    if p.ndim == 1 and len(p) == a:
        p = p[None]
    elif p.ndim != 2 or p.shape[1] != a:
        raise AdverbsError(f"verb {verb.name!r}: adverb points must be (C, {a}), got shape {p.shape}")
    clocks = np.ascontiguousarray(clocks, dtype=float).reshape(-1)
    if len(clocks) != len(p):
        raise AdverbsError(f"verb {verb.name!r}: {len(p)} adverb points but {len(clocks)} clock times")
    if not np.isfinite(clocks).all():
        raise AdverbsError("clock time must be a finite number of seconds")
    return _sample_state(verb, p, clocks, state)


def pose(verb: Verb, p: np.ndarray, clock: float, state: SamplingState | None = None) -> np.ndarray:
    """DOFs ``(D,)`` of one creature at adverb point ``p (A,)`` and clock time ``clock``: :func:`sample` with ``C = 1``.

    Keep a ``state = verb.state()`` and pass it every call to reuse the weights and keytimes while
    ``p`` stays the same (the arguments are checked as in :func:`sample`, with fewer array calls).
    """
    clock = float(clock)
    if not math.isfinite(clock):
        raise AdverbsError(f"clock time must be a finite number of seconds, got {clock}")
    p = np.asarray(p, dtype=float)
    if p.shape != (len(verb.adverbs),):
        raise AdverbsError(f"verb {verb.name!r} takes {len(verb.adverbs)} adverbs, got shape {p.shape}")
    if verb.goal is not None:  # the goal chain's solve (compiled, a call of its own): the general path
        return _sample_state(verb, p[None], np.array([clock]), state)[0][0]
    if state is None:
        state = SamplingState.new(verb, 1)
    state.check(verb, 1)
    # One compiled call: the point checked and cached if new, then sampled (SamplingState.update and run_kernel's
    # arithmetic for one creature; a test holds the two paths together).
    out = np.empty(verb.num_dofs)
    d = verb.num_dofs if verb.cyclic else 0
    refused = pose_one(
        p, *verb.interpolator.kernel_tables, verb.log_intervals, verb.interval_bounds, verb.seam_table[:, :d],
        verb.segments, verb.generic_keytimes, clock, mode(verb), SEAM_BLEND, MAX_GAIN, SHORTEST_CYCLE, LONGEST_CYCLE,
        state.points, state.cached, state.weights, state.keytimes, state.seam[:, :d], state.cycle, out,
    )  # fmt: skip
    if refused:
        state.update(verb, p[None])  # says why, as the general path does, and changes nothing
        raise AdverbsError(f"verb {verb.name!r}: adverb point refused")  # (update has raised already)
    return out


def clocks_dofs(verb: Verb, state: SamplingState, rows: np.ndarray, clocks: np.ndarray) -> np.ndarray:
    """DOFs ``(Q, D)`` of the creatures ``rows (Q,)`` of an up-to-date ``state`` at clock times ``clocks (Q,)``.

    The kernel's many-queries form, for one creature at many times (a whole clip) or any mix; the
    state's cache is read, not changed (its ``cycle`` is left as it was).
    """
    return run_kernel(verb, state, rows, clocks, mode(verb))


def dofs(verb: Verb, p: np.ndarray, t: np.ndarray) -> np.ndarray:
    """DOFs ``(Q, D)`` at adverb points ``p (Q, A)`` and *generic* times ``t (Q,)`` in ``[0, 1]``: the interpolated
    curves alone (no cycles, no seam, no goal correction).

    The kernel run on generic times; weights of many points are computed in blocks.
    """
    p = np.asarray(p, dtype=float)
    if p.shape[-1:] != (len(verb.adverbs),):
        raise AdverbsError(f"verb {verb.name!r} takes {len(verb.adverbs)} adverbs, got points of shape {p.shape}")
    p = np.ascontiguousarray(p.reshape(-1, len(verb.adverbs)))
    t = np.asarray(t, dtype=float).reshape(-1)
    if not np.all(np.isfinite(p)):
        raise AdverbsError("adverb values must be finite numbers (got NaN or infinity)")
    if not np.all(np.isfinite(t)):
        raise AdverbsError("generic times must be finite numbers")
    if len(p) != len(t):
        raise AdverbsError(f"dofs: {len(p)} adverb points but {len(t)} times")
    return generic_dofs(verb, point_weights(verb, p), np.arange(len(t)), t)


def point_weights(verb: Verb, p: np.ndarray) -> np.ndarray:
    """The sampling kernel's weights ``(C, W)`` at adverb points ``p (C, A)`` (finite, checked), row by row in compiled
    code: each point's the same bits alone or among many (:meth:`Verb.weights` multiplies matrices, whose sums BLAS
    orders by their size)."""
    p = np.ascontiguousarray(p, dtype=float)
    e = len(verb.examples)
    no_keytimes, no_seam = np.zeros((e, 0)), np.zeros((verb.weight_columns, 0))
    w = np.empty((len(p), verb.weight_columns))
    for a in range(0, len(p), CHUNK):
        refresh_batch(
            p, np.arange(a, min(a + CHUNK, len(p))), *verb.interpolator.kernel_tables, no_keytimes, np.zeros((2, 0)),
            no_seam, w, np.empty((len(p), 1)), np.empty((len(p), 0)),
        )  # fmt: skip
    return w


def generic_dofs(verb: Verb, w: np.ndarray, rows: np.ndarray, t: np.ndarray) -> np.ndarray:
    """DOFs ``(Q, D)`` at generic times ``t (Q,)``, query ``q`` at the point of weights ``w[rows[q]]`` (``w (C, W)``,
    :func:`point_weights`): :func:`dofs` with each point's weights worked out once however many times are asked of it."""
    out = np.empty((len(t), verb.num_dofs))
    no_keytimes, no_seam = np.zeros((len(verb.examples), 0)), np.zeros((verb.weight_columns, 0))
    with one_blas_thread():
        for a in range(0, len(t), CHUNK):
            b = min(a + CHUNK, len(t))
            sample_batch(
                verb.segments, w, no_keytimes, verb.generic_keytimes, no_seam, no_seam, _NO_COLUMNS, _NO_WINDOW,
                np.ascontiguousarray(rows[a:b], dtype=np.int64), t[a:b], GENERIC, SEAM_BLEND, out[a:b],
                np.empty(b - a, dtype=np.int64),
            )  # fmt: skip
    return out


def advance(verb: Verb, state: SamplingState, dofs: np.ndarray, dt: float | np.ndarray) -> SamplingState:
    """Move each creature's root ``state.root`` on by ``dt`` seconds at the velocities of its ``dofs (C, D)``.

    The per-frame form of the root integration in :meth:`~adverbs.motion.encoding.DofEncoding.root_path`;
    the state is updated in place and returned.
    """
    state.root = verb.encoding.advance_root(state.root, dofs, dt)
    return state


# ----- the reference path: explicit coefficients, the time warp and the spline, as in the paper -----


def sample_reference(verb: Verb, points: np.ndarray, clocks: np.ndarray) -> np.ndarray:
    """What :func:`sample` computes, written out plainly, one creature at a time; ``(C, D)``.

    Every control point and log keytime interval by eq. 3 with explicit linear and radial
    coefficients (outside the examples' hull, the DOFs a verb holds taken at the hull's nearest point), the cycle and the time warp with :mod:`~adverbs.interp.timewarp`, the spline with
    :func:`~adverbs.interp.bspline.evaluate`, the seam from the spline's end values, the goal's offset from
    :func:`~adverbs.verb.goal.solve`'s NumPy reference (on these keytimes) weighted by :func:`~adverbs.verb.goal.weight`.
    """
    ip = verb.interpolator
    coef = ip.fit(verb.coefficients)
    logk = ip.fit(verb.log_intervals)
    points = np.asarray(points, dtype=float).reshape(-1, len(verb.adverbs))
    out = []
    for p, clock in zip(points, np.asarray(clocks, dtype=float).reshape(-1)):
        cp = _held_control_points(verb, p, coef)
        k = np.concatenate([[0.0], np.cumsum(np.exp(np.clip(ip.evaluate(p, logk), *verb.interval_bounds)))])
        end = k[-1]
        cycle = max(math.ceil(clock / end - CYCLE_EPS) - 1, 0) if verb.cyclic else 0
        local = min(max(clock - cycle * end, 0.0), end)
        t = timewarp.generic_time(np.array(local), k, verb.generic_keytimes)
        d = bspline.evaluate(cp, t)
        if verb.goal is not None:
            offset = goals.solve(verb, verb.goal, verb.blend(p)[None], k[None], p[None], compiled=False)[0]
            d[verb.goal.columns] += goals.weight(verb.goal, t) * offset
        if cycle > 0:
            v0, _, v1, _ = bspline.ends(cp)
            s = min(local / (SEAM_BLEND * end), 1.0)
            fade = np.full(len(d), 1.0 - s * s * (3.0 - 2.0 * s))
            fade[:VELOCITIES] -= 3.0 * s * (1.0 - s)
            d = d + fade * (v1 - v0)
        out.append(d)
    return np.stack(out)


def dofs_reference(verb: Verb, p: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The same as :func:`dofs` the slow way: every control point by eq. 3, then the spline."""
    ip = verb.interpolator
    coef = ip.fit(verb.coefficients)
    out = []
    for pi, ti in zip(np.asarray(p, dtype=float).reshape(-1, len(verb.adverbs)), np.asarray(t).reshape(-1)):
        out.append(bspline.evaluate(_held_control_points(verb, pi, coef), np.array(ti)))
    return np.stack(out)


def _held_control_points(verb: Verb, p: np.ndarray, coef: np.ndarray) -> np.ndarray:
    """Control points ``(NumCP, D)`` at ``p`` by eq. 3 (``coef`` the interpolator's fit of the coefficients), each DOF
    a verb holds past its examples (``1 − follows``) taken at the point ``h`` of the examples' hull nearest ``p``:
    ``v(p) + (1 − follows) (v(h) − v(p))``."""
    ip = verb.interpolator
    cp = ip.evaluate(p, coef)
    if verb.weight_columns == len(verb.examples):
        return cp
    h, dist = hull_nearest_reference(ip.kernel_tables[2], (p - ip.centre) / ip.scale)
    if dist <= HULL_TOL:
        return cp
    return cp + (1.0 - verb.follows) * (ip.evaluate(h * ip.scale + ip.centre, coef) - cp)
