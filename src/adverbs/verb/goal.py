"""Goals: a joint put where its adverbs ask, by IK at a keytime, on top of the interpolated motion.

A verb's adverbs may be a joint's position at a keytime (``joint_position`` measures: a reach's hand at
its peak). Interpolation alone puts the joint near such a goal between examples, not on it; where the
examples' limbs saturate (an arm already straight over the head) a blend of them misses by centimetres
between examples and by decimetres past them. A *goal chain* (spec ``[goal] chain = [...]``: joints
between the body root and the goal's joint) makes the verb correct that: for each adverb point, an
offset ``Δ`` on the chain's rotation DOFs that puts the joint on the goal at the keytime, added to the
motion with a weight that rises by smoothstep from 0 at the keytime before to 1 at the keytime and falls
back to 0 at the keytime after (in generic time; at a one-shot verb's last keytime it stays 1), so the
motion is unchanged at its other keytimes and stays smooth.

``Δ`` is solved once per adverb point (when a creature's point changes, in
:meth:`~adverbs.verb.sampling.SamplingState.update`), by Levenberg–Marquardt on the chain's DOFs at the
keytime's pose: least squares on the goal error plus ``MU² |Δ|²``, from ``Δ = 0``. The pull towards no offset
leaves a reachable goal a little short (a tenth of a millimetre, median, inside the reach's examples; nothing at
the examples); an unreachable one leaves the limb at its nearest reach rather than flinging it.
The joint is placed as the ``joint_position`` measure reads it: the body root's path integrated from its
velocities up to the keytime, in the character's frame at the start (x left, y up, z forward, from the
body root's starting ground point).

The solve is compiled (:mod:`._goal_kernel`; a crowd's points are shared among numba's threads): about 10 µs a
point on one core for the shipped reach, where the NumPy reference (:func:`_solve`, ``solve(compiled=False)``,
what :func:`~adverbs.verb.sampling.sample_reference` uses) takes 0.3–0.5 ms. ``tests/test_goal.py`` holds the two to
1e-8 rad (1e-6 for goals far out of reach, which end where :data:`ITERATIONS` steps leave them).

No warm start: every solve starts from ``Δ = 0``, so it is a function of the point, and a creature's motion at a
point never depends on the points it passed through (a pose at a point is the same however it is asked: in one call,
through a kept state, in a crowd, by the reference). Starting from the creature's last solution was measured and
refused. The cost is flat
along the chain's redundant directions (15 DOFs for 3 coordinates; curvature ``MU²`` there, about what the arm's
second-order terms are), so the solve ends, on :data:`SETTLED` or at :data:`ITERATIONS`, wherever its path leaves
it along them rather than at one minimum: with goals moved 5 mm a frame for 30 frames, 11% of the warm-started
offsets inside the examples' box ended more than 1e-6 rad from the solve from zero (at most 0.12 rad), and 40%
25% past the examples (at most 0.59 rad), for a quarter fewer steps (12.1 → 9.0 inside, 19.2 → 16.6 past). A warm
start becomes right once the solve converges to its minimum (Newton steps with the chain's second derivatives,
say): a change of the motion, to be made on purpose.

Nor would that make a moved goal cost microseconds (session 63, measured on the shipped reach). Of a solve's 12-13 µs,
5 are the point's fixed work (the root's 48 integration steps 3.2 of them) and 0.65 each step. A table of ``Δ`` over
the adverb box (17³ nodes to 30% past the examples, tricubic) misses the goal by 1.1 mm median and 8 mm at the 95th
percentile inside the examples' box (the solve: 0.13 and 0.33), and does as badly with every node's solve polished to
its minimum by Newton steps (exact Hessian; 1-5 steps converge 99% of points): the minimum itself moves fast across
the box, since the nonlinear terms cancel up to nine tenths of ``MU²``'s curvature along the chain's redundant
directions. A fixed number of damped steps (a smooth function of the point) misses unreachable goals by 4x more and
is as steep. A goal cheap to move needs a better-conditioned aim (a larger ``MU``, a prior over the chain's poses):
a change of the reach's motion.
"""

from __future__ import annotations

import os
import weakref
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numba
import numpy as np

from ..errors import AdverbsError
from ..kinematics import quat
from ..kinematics.fk import forward_kinematics
from ..motion.encoding import DofEncoding
from ..motion.heading import heading
from . import _goal_kernel
from ._sampling_kernel import ONE_SHOT, sample_batch

MU = 0.01  # metres per unit of DOF: how much the solve prefers a small offset to the last centimetres of reach
ITERATIONS = 40  # Levenberg–Marquardt steps at most (the reach: 9 median in its examples' box, 8% end here; 31% 25% past)
TOLERANCE = 1e-9  # metres: a goal this close is met (the examples' own, where the offset stays zero)
STEPS = 48  # steps of the root's integration from the start to the goal's keytime
SETTLED = 1e-10  # a step that lowers the cost by less than this fraction ends the solve (out of reach: a minimum)
LONGEST = 1e6  # seconds: a point whose motion lasts longer than this (or whose keytimes do not increase) gets no offset
LAMBDA = 1e-3  # Levenberg–Marquardt's damping at the first step
BOUND = 2.0  # radians: no chain joint's offset turns it further (a goal far out of reach pulls the arm round otherwise)
PER_THREAD = 16  # points: fewer than this many per thread are solved on the calling thread alone
THREADS: int | None = None  # threads a crowd's solve may use (None: numba's count); the answer is the same on any
AXES = "xyz"


@dataclass(frozen=True, eq=False)
class Goal:
    """A verb's goal: ``joint`` at ``keytime`` where adverbs ``adverbs`` (its ``axes``, 0-2 for x, y, z) say.

    ``chain`` names the joints whose rotation DOFs ``columns (K,)`` the correction moves; ``window (3,)``
    is the generic times of the keytime before, the keytime and the keytime after (the last equal to the
    keytime's own when the correction holds to the end of a one-shot verb).
    """

    chain: tuple[str, ...]
    joint: int
    keytime: int
    adverbs: tuple[int, ...]
    axes: tuple[int, ...]
    columns: np.ndarray
    window: np.ndarray
    joints: np.ndarray  # (len(chain),) the chain's joint indices; its columns are three per joint, in this order
    path: tuple = ()  # the compiled solve's tables of the goal joint's ancestors (see :func:`_path`)

    @classmethod
    def build(
        cls,
        chain: Sequence[str],
        adverbs: Sequence,
        encoding: DofEncoding,
        generic: np.ndarray,
        cyclic: bool,
    ) -> Goal:
        """The goal of a verb with goal chain ``chain``, adverbs ``adverbs`` (with their measures) and generic
        keytimes ``generic (N,)``; an :class:`~adverbs.errors.AdverbsError` starting ``goal:`` names what is wrong."""
        skel = encoding.skeleton
        chain = tuple(chain)
        if encoding.kind != "logquat":
            raise AdverbsError(f"goal: a goal chain needs the logquat encoding (the default), not {encoding.kind!r}")
        if not chain or not all(isinstance(j, str) for j in chain):
            raise AdverbsError(f"goal: chain must be a list of one or more joint names, got {chain!r}")
        goal_adverbs = [
            i for i, a in enumerate(adverbs) if a.measure is not None and a.measure.get("kind") == "joint_position"
        ]
        if not goal_adverbs:
            raise AdverbsError(
                "goal: a goal chain needs adverbs measured as a joint's position (measure kind 'joint_position'); "
                "this verb has none"
            )
        first = adverbs[goal_adverbs[0]]
        for i in goal_adverbs[1:]:
            for key in ("joint", "keytime"):
                if adverbs[i].measure[key] != first.measure[key]:
                    raise AdverbsError(
                        f"goal: adverbs {first.name!r} and {adverbs[i].name!r} measure different {key}s "
                        f"({first.measure[key]!r}, {adverbs[i].measure[key]!r}); a goal is one joint at one keytime"
                    )
        axes = [AXES.index(adverbs[i].measure["axis"]) for i in goal_adverbs]
        if len(set(axes)) != len(axes):
            raise AdverbsError(f"goal: two adverbs measure axis {AXES[max(axes, key=axes.count)]!r} of the goal")
        joint = skel.index(first.measure["joint"])
        n = len(generic)
        k = int(first.measure["keytime"])
        if k == 0:
            raise AdverbsError(
                "goal: the goal is at keytime 0, where the character's frame is taken; put it at a later keytime"
            )
        if cyclic and k == n - 1:
            raise AdverbsError(f"goal: keytime {k} ends the cycle (it is keytime 0 of the next); use keytime 0..{n - 2}")
        above = set(skel.ancestors(joint))
        root = encoding.body_root
        columns, joints = [], []
        for name in chain:
            if name not in skel.names:
                raise AdverbsError(f"goal: chain names joint {name!r}, which the skeleton does not have")
            j = skel.index(name)
            if j not in above or j == root or j in skel.ancestors(root):
                raise AdverbsError(
                    f"goal: chain joint {name!r} is not between the body root {skel.names[root]!r} and the goal's "
                    f"joint {skel.names[joint]!r}: it must be above {skel.names[joint]!r} and below "
                    f"{skel.names[root]!r} (the body root carries the legs)"
                )
            joints.append(j)
            columns.extend(encoding.names.index(f"{name}.{a}") for a in ("rx", "ry", "rz"))
        if len(set(chain)) != len(chain):
            raise AdverbsError(f"goal: chain names a joint twice: {chain!r}")
        after = generic[k + 1] if k + 1 < n else generic[k]
        window = np.array([generic[k - 1], generic[k], after])
        return cls(
            chain, joint, k, tuple(goal_adverbs), tuple(axes), np.array(columns, dtype=np.int64), window,
            np.array(joints), _path(encoding, joint, joints, axes, goal_adverbs),
        )  # fmt: skip


def _path(encoding: DofEncoding, joint: int, chain: list[int], axes: list[int], adverbs: list[int]) -> tuple:
    """What the compiled solve reads of the goal joint's ancestors, root first (``P`` of them): each one's parent's
    place in the path (−1: none), first rotation and translation DOF columns (−1: none), reference rotation ``(P, 4)``,
    base translation ``(P, 3)`` and block of the chain's offset (−1: not in the chain); then the body root's place in
    the path, the fixed frame it is decoded below (``parent_inv (4,)``, ``parent_pos (3,)``, whether there is one) and
    its hips' axis ``lateral (3,)``; last the goal's axes ``(M,)`` and the adverbs that give them ``(M,)``."""
    skel = encoding.skeleton
    joints = skel.ancestors(joint)[::-1]
    place = {j: i for i, j in enumerate(joints)}
    parent = np.array([place.get(int(skel.parents[j]), -1) for j in joints], dtype=np.int64)
    rotated = list(encoding.rotated)
    rot_col = np.array([4 + 3 * rotated.index(j) if j in rotated else -1 for j in joints], dtype=np.int64)
    translated = list(encoding.translated)
    first = 4 + 3 * len(rotated)
    trans_col = np.array([first + 3 * translated.index(j) if j in translated else -1 for j in joints], dtype=np.int64)
    block = np.array([chain.index(j) if j in chain else -1 for j in joints], dtype=np.int64)
    has_parent, parent_inv, parent_pos = encoding.above_body
    return (
        parent, rot_col, trans_col, np.ascontiguousarray(encoding.reference[joints], dtype=float),
        np.ascontiguousarray(encoding.base_translations[joints], dtype=float), block, place[encoding.body_root],
        np.ascontiguousarray(parent_inv, dtype=float), np.ascontiguousarray(parent_pos, dtype=float), bool(has_parent),
        np.ascontiguousarray(encoding.lateral, dtype=float), np.array(axes, dtype=np.int64),
        np.array(adverbs, dtype=np.int64),
    )  # fmt: skip


def weight(goal: Goal, t: np.ndarray) -> np.ndarray:
    """How much of the offset is added at generic times ``t (...)``: smoothstep up over the window's first
    half, down over its second (held at 1 past the keytime when the window ends there)."""
    a, m, b = goal.window
    t = np.asarray(t, dtype=float)
    up = np.clip((t - a) / (m - a), 0.0, 1.0)
    down = np.ones_like(t) if b <= m else np.clip((b - t) / (b - m), 0.0, 1.0)
    s = np.where(t < m, up, down)
    return s * s * (3.0 - 2.0 * s)


def misses(verb) -> np.ndarray:
    """What the uncorrected motion of each example misses its own goal by, ``(E, M)`` metres (``M`` goal axes).

    The B-spline fit and the goal's model (the root integrated in :data:`STEPS` steps) differ from the
    measure on the captured frames by a millimetre or so. :func:`solve` aims at the asked goal plus these
    misses, blended by the point's weights, so that at the examples the offset is exactly zero and each
    example is reproduced as captured.
    """
    e = len(verb.examples)
    model = _Model(verb, verb.goal, np.eye(e, verb.weight_columns), verb.keytimes_table)
    at, _ = model.reached(np.arange(e), np.zeros((e, len(verb.goal.columns))))
    own = at - verb.points[:, list(verb.goal.adverbs)]
    # A state's held part (``w(h) − w(p)``, see Verb.follows) blends no miss: the misses are the examples' own.
    return np.concatenate([own, np.zeros((verb.weight_columns - e, own.shape[1]))])


class _Model:
    """Where the goal joint is, as the ``joint_position`` measure reads it, for R adverb points (their weights
    ``(R, E)`` and keytimes ``(R, N)``) with offsets on the goal chain: the uncorrected pose at the keytime, the
    body root's path integrated to it, the character's frame at the start."""

    def __init__(self, verb, goal: Goal, weights: np.ndarray, keytimes: np.ndarray):
        r = len(weights)
        enc = self.encoding = verb.encoding
        self.parents, self.goal = verb.skeleton.parents, goal
        grid = np.linspace(0.0, 1.0, STEPS + 1)
        weights = np.ascontiguousarray(weights, dtype=float)
        keytimes = np.ascontiguousarray(keytimes, dtype=float)
        d = np.empty((r, STEPS + 1, verb.num_dofs))
        self.root = np.empty((r, 3))  # the body root at the keytime
        no_seam, no_columns, rows = np.zeros((r, 0)), np.zeros(0, dtype=np.int64), np.empty(STEPS + 1, dtype=np.int64)
        for i in range(r):  # one creature at a time (fewer queries than the kernel groups): a batch gives what one does
            rows[:] = i
            sample_batch(
                verb.segments, weights, keytimes, verb.generic_keytimes, no_seam, no_seam, no_columns, goal.window,
                rows, keytimes[i, goal.keytime] * grid, ONE_SHOT, 0.0, d[i], np.empty(STEPS + 1, np.int64),
            )  # fmt: skip
            self.root[i] = enc.root_path(d[i], STEPS / keytimes[i, goal.keytime])[-1]
        rot0, trans0 = enc.decode_pose(d[:, 0], np.zeros((r, 3)))
        gpos0, grot0 = forward_kinematics(self.parents, rot0, trans0)
        body = enc.body_root
        self.to_local = quat.about_y(-heading(grot0[:, body], enc.lateral))
        self.origin = gpos0[:, body] * np.array([1.0, 0.0, 1.0])
        self.pose = d[:, -1]

    def reached(self, sel: np.ndarray, delta: np.ndarray, jacobian: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
        """The goal joint's measured coordinates ``(R', len(axes))`` of rows ``sel`` with offsets ``delta (R', K)``
        and (``jacobian``) their derivatives ``(R', len(axes), K)`` with respect to the offsets.

        A chain joint's rotation is ``ref · exp(v)``; moving ``v`` by ``δ`` turns it by ``Jr(v) δ`` in its own
        frame (``Jr`` the right Jacobian of the exponential map): about world axes ``ω_k`` through the joint,
        which swing the goal joint ``p`` by ``ω_k × (p − o_k)``. Analytic, so two paths whose weights differ
        by rounding solve to the same offsets (a finite-difference Jacobian multiplied that rounding a
        million times).
        """
        g = self.goal
        dofs = self.pose[sel].copy()
        dofs[:, g.columns] += delta
        rot, trans = self.encoding.decode_pose(dofs, self.root[sel])
        gpos, grot = forward_kinematics(self.parents, rot, trans)
        to_local = self.to_local[sel]
        axes = list(g.axes)
        at = quat.rotate(to_local, gpos[:, g.joint] - self.origin[sel])[:, axes]
        if not jacobian:
            return at, None
        turns = np.concatenate(
            [
                quat.rotate(grot[:, j, None], _right_jacobian(dofs[:, g.columns[3 * i : 3 * i + 3]]).transpose(0, 2, 1))
                for i, j in enumerate(g.joints)
            ],
            axis=1,
        )  # (R', K, 3): ω_k
        arm = gpos[:, g.joint, None] - np.repeat(gpos[:, g.joints], 3, axis=1)  # (R', K, 3): p − o_k
        return at, quat.rotate(to_local[:, None], np.cross(turns, arm))[..., axes].transpose(0, 2, 1)


def _right_jacobian(v: np.ndarray) -> np.ndarray:
    """``Jr(v) (..., 3, 3)`` of rotation vectors ``v (..., 3)``: ``exp(v + δ) ≈ exp(v) exp(Jr(v) δ)``."""
    theta2 = np.sum(v * v, axis=-1)
    theta = np.sqrt(theta2)
    small = theta < 1e-4
    t = np.where(small, 1.0, theta)
    a = np.where(small, 0.5 - theta2 / 24.0, (1.0 - np.cos(t)) / (t * t))  # (1 − cos θ) / θ²
    b = np.where(small, 1.0 / 6.0 - theta2 / 120.0, (t - np.sin(t)) / (t * t * t))  # (θ − sin θ) / θ³
    k = quat.cross_matrix(v)
    return np.eye(3) - a[..., None, None] * k + b[..., None, None] * (k @ k)


def solve(
    verb, goal: Goal, weights: np.ndarray, keytimes: np.ndarray, points: np.ndarray, compiled: bool = True
) -> np.ndarray:
    """Offsets ``(R, K)`` on the goal chain's DOFs that put the goal joint where ``points (R, A)`` ask.

    ``weights (R, E)`` and ``keytimes (R, N)`` are those of the points (from the sampling state). The aim is
    the asked goal plus the examples' own :func:`misses` blended by ``weights``: zero offset at the examples.
    ``compiled``: by :mod:`._goal_kernel` (default), or by the NumPy reference it is held to.
    """
    if compiled:  # the same rules, row by row in the kernel
        return _solve_compiled(verb, goal, weights, keytimes, points)
    k = len(goal.columns)
    whole = np.zeros((len(points), k))
    # Points so far out that the motion degenerates (keytimes that overflow or collapse) get no offset: the
    # synthesis refuses them, and a run-time creature must not be stopped by them.
    with np.errstate(all="ignore"):
        sane = np.all(np.isfinite(keytimes), axis=1) & np.all(np.diff(keytimes, axis=1) > 0, axis=1)
        sane &= np.all(np.isfinite(weights), axis=1) & (keytimes[:, -1] <= LONGEST)
        if sane.any():
            whole[sane] = _solve(verb, goal, weights[sane], keytimes[sane], np.asarray(points, dtype=float)[sane])
    whole[~np.isfinite(whole).all(axis=1)] = 0.0
    return whole


def _solve(verb, goal: Goal, weights: np.ndarray, keytimes: np.ndarray, points: np.ndarray) -> np.ndarray:
    """:func:`solve` for points whose motion has not degenerated: the NumPy reference."""
    r = len(points)
    k = len(goal.columns)
    out = np.zeros((r, k))
    model = _Model(verb, goal, weights, keytimes)
    target = np.asarray(points, dtype=float)[:, list(goal.adverbs)] + weights @ verb.goal_misses
    res = target - model.reached(np.arange(r), out)[0]
    cost = np.sum(res * res, axis=1)  # with MU² |Δ|², what the solve minimizes
    lam = np.full(r, LAMBDA)
    active = np.sqrt(cost) > TOLERANCE
    eye = np.eye(k)
    for _ in range(ITERATIONS):
        sel = np.flatnonzero(active)
        if len(sel) == 0:
            break
        delta = out[sel]
        _, jac = model.reached(sel, delta, jacobian=True)
        jt = jac.transpose(0, 2, 1)
        a = jt @ jac + (MU * MU + lam[sel])[:, None, None] * eye
        step = np.linalg.solve(a, (jt @ res[sel, :, None]) - MU * MU * delta[..., None])[..., 0]
        moved = _bounded(delta + step)
        trial = target[sel] - model.reached(sel, moved)[0]
        trial_cost = np.sum(trial * trial, axis=1) + MU * MU * np.sum(moved**2, axis=1)
        better = trial_cost < cost[sel]
        settled = better & (cost[sel] - trial_cost <= SETTLED * cost[sel])
        took = sel[better]
        out[took] = moved[better]
        res[took] = trial[better]
        cost[took] = trial_cost[better]
        lam[took] = np.maximum(lam[took] / 3.0, 1e-9)
        lam[sel[~better]] *= 4.0
        # Done: met, or no step makes it better (an unreachable goal at its nearest reach).
        small = np.sqrt(np.sum(step * step, axis=1)) < 1e-12
        active[sel] = (np.sqrt(np.sum(res[sel] ** 2, axis=1)) > TOLERANCE) & ~small & ~settled & (lam[sel] < 1e8)
    return out


def _bounded(delta: np.ndarray) -> np.ndarray:
    """Offsets ``(R, K)`` with each chain joint's (three columns, a rotation vector) no longer than :data:`BOUND`."""
    turns = delta.reshape(len(delta), -1, 3)
    x, y, z = turns[..., 0], turns[..., 1], turns[..., 2]
    size = np.sqrt(x * x + y * y + z * z)[..., None]
    return np.where(size > BOUND, turns * (BOUND / np.where(size > BOUND, size, 1.0)), turns).reshape(delta.shape)


_GRID = np.linspace(0.0, 1.0, STEPS + 1)


def _solve_compiled(verb, goal: Goal, weights: np.ndarray, keytimes: np.ndarray, points: np.ndarray) -> np.ndarray:
    """:func:`solve` by the compiled kernel: one call, the degenerate points found and given no offset in it."""
    r = len(points)
    out = np.empty((r, len(goal.columns)))
    args = (
        *_tables(verb, goal), np.ascontiguousarray(weights, dtype=float), np.ascontiguousarray(keytimes, dtype=float),
        verb.generic_keytimes, _GRID, goal.keytime, np.ascontiguousarray(points, dtype=float), verb.goal_misses,
        *goal.path, MU, LAMBDA, ITERATIONS, TOLERANCE, SETTLED, LONGEST, BOUND, out, np.empty(r, dtype=np.int64),
    )  # fmt: skip
    _in_threads(_goal_kernel.solve_rows, r, args)
    return out


_TABLES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _tables(verb, goal: Goal) -> tuple:
    """The verb's tables for the compiled solve (:func:`._goal_kernel.tables`, once per verb) and the columns they hold,
    its numbers of control points and DOFs."""
    got = _TABLES.get(verb)
    if got is None:
        parent, rot_col, trans_col, *_, body = goal.path[:7]
        key = [3] + [c + a for c in rot_col[:-1] if c >= 0 for a in range(3)]  # the goal joint's rotation: not read
        key += [c + a for c in trans_col if c >= 0 for a in range(3)]
        key_cols = np.array(key, dtype=np.int64)
        start = [3] + [rot_col[body] + a for a in range(3)]
        if trans_col[body] >= 0:  # an anchored verb's body root stands off its feet
            start += [trans_col[body] + a for a in range(3)]
        start_cols = np.array(start, dtype=np.int64)
        velocities, key_pose, start_pose = _goal_kernel.tables(
            verb.segments, np.ascontiguousarray(verb.keytimes_table[:1]), verb.generic_keytimes, goal.keytime, _GRID,
            key_cols, start_cols,
        )  # fmt: skip
        got = _TABLES[verb] = (velocities, key_pose, start_pose, key_cols, start_cols) + verb.segments.shape[::2]
    return got


_POOL: dict = {}  # the threads many rows are solved on, by process and number, made on first use


def _threads() -> int:
    """How many threads a large solve may use: :data:`THREADS`, or numba's count (every core, or ``NUMBA_NUM_THREADS``)."""
    return numba.config.NUMBA_NUM_THREADS if THREADS is None else max(1, int(THREADS))


def _in_threads(kernel, rows: int, args: tuple) -> None:
    """``kernel(lo, hi, *args)`` over contiguous ranges covering ``rows``, on up to :func:`_threads` threads (the kernel
    releases the GIL), at least :data:`PER_THREAD` rows each; rows are independent, so the answer is the same on any
    number of threads."""
    n = max(1, min(_threads(), rows // PER_THREAD))
    if n == 1:
        kernel(0, rows, *args)
        return
    key = (os.getpid(), n)  # a process forked from this one has none of its threads: it makes its own pool
    pool = _POOL.get(key)
    if pool is None:
        pool = _POOL[key] = ThreadPoolExecutor(n - 1, thread_name_prefix="adverbs-goal")
    bounds = [rows * i // n for i in range(n + 1)]
    futures = [pool.submit(kernel, bounds[i], bounds[i + 1], *args) for i in range(1, n)]
    kernel(bounds[0], bounds[1], *args)  # this thread takes the first range
    for f in futures:
        f.result()
