"""A verb as immutable tables: example points, keytimes, B-spline coefficients, encoding, constraints (§3, §4).

A built verb is data that any number of creatures read at once. Nothing in it changes after it is
made (its arrays are read-only); everything that changes while a creature moves — the weights and
keytimes cached for its adverb point, its cycle, its root — lives in a
:class:`~adverbs.verb.sampling.SamplingState` the caller owns.

The tables are what the paper interpolates: every control point and every keytime is a function of
the adverb point ``p`` through the cardinal weights of :class:`~adverbs.interp.rbf.AdverbInterpolator`
(eqs. 3, 4), ``b(p) = Σ_i w_i(p) b_i``.

Keytime policy: the paper interpolates keytimes directly (eq. 4), which can make them cross when
extrapolating. Here the *intervals* between keytimes are interpolated as logarithms,
``K_{m+1}(p) − K_m(p) = exp(Σ_i w_i(p) log(K_{i,m+1} − K_{i,m}))``, so keytimes are strictly increasing at
every ``p``, examples are still reproduced exactly, and durations extrapolate multiplicatively (a walk
25% faster than the fastest example gets shorter, never negative, steps).

Building the tables is :func:`adverbs.verb.fit.build_verb`, saving and loading them
:mod:`adverbs.verb.store`, sampling them :mod:`adverbs.verb.sampling` and whole motions
:mod:`adverbs.verb.synthesis`; the methods here are thin calls of those.
"""

from __future__ import annotations

from collections.abc import Sequence
import dataclasses
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..errors import AdverbsError
from ..interp import bspline, timewarp
from ..interp.rbf import AdverbInterpolator
from ..kinematics import quat
from ..kinematics.ik import LegChains
from ..kinematics.skeleton import Skeleton
from ..motion.clip import Clip
from ..motion.encoding import DofEncoding, stance_joints
from . import sampling, synthesis
from .constraints import Constraint, Hold, check_constraint, default_holds
from . import goal as goals
from .goal import Goal
from ._sampling_kernel import HULL_TOL, VELOCITIES
from ..interp.rbf import hull_nearest_reference


@dataclass(frozen=True)
class Adverb:
    """One axis of a verb's parameter space; ``measure`` says how it is read off a motion (or ``None``)."""

    name: str
    unit: str = ""
    measure: dict | None = None


@dataclass(eq=False)
class Example:
    """One example motion, cut and annotated: the input of :func:`~adverbs.verb.fit.build_verb`.

    ``keytimes (N,)`` are clock seconds from 0 to the clip's duration; ``point (A,)`` its adverb values.
    """

    name: str
    clip: Clip
    keytimes: np.ndarray
    point: np.ndarray
    source: str = ""
    part: str = ""
    refine: bool = False  # a local refinement: radial part only, not in the linear fit
    keytime_names: tuple[str, ...] = ()  # e.g. ("left strike", "right toe-off", ...)


@dataclass(frozen=True)
class ExampleRecord:
    """What a built verb keeps about each example (its motion lives in the coefficient table)."""

    name: str
    source: str
    part: str
    fit_error: float = field(default=0.0)  # largest joint-position error of the B-spline fit at the frames, metres
    refine: bool = False
    fine_error: float = 0.0  # largest pose error of the fit on a grid 4x finer than the frames, metres


TIMINGS = ("extrapolate", "clamp")  # Verb.timing: how keytime intervals behave past the examples
LIFT_SAMPLES = 128  # Verb.lift_table: samples of each example's foot heights over its generic time
LEVEL_SAMPLES = 16  # Verb.contact_levels: poses sampled evenly over each foot's hold ...
LEVEL_BLOCK = 256  # ... for this many creatures at a time
LEVELS_KEPT = 4096  # single points' levels a verb keeps (forgotten all at once past this)
SETTLING = 0.1  # m/s²: the least root acceleration a verb's examples are taken to have (a stand's sway had 0.1-0.2)
ACCELERATION_SAMPLES = 129  # Verb.root_velocity_samples: each example's root velocities over its generic time
FRAME = 1.0 / 30.0  # seconds: the step over which Verb.carry_limit reads a verb's root acceleration, a frame's
SPEED_SAMPLES = 65  # Verb.joint_speed_profile: each example's poses over its generic time


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)  # a private copy: nobody else holds a reference that could write to it
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Verb:
    """A parameterized motion: immutable tables shared by every creature that plays it.

    Make one with :func:`~adverbs.verb.fit.build_verb` (or :func:`~adverbs.verb.fit.build_from_spec`,
    :func:`~adverbs.verb.store.load_verb`).

    Attributes
    ----------
    points : (E, A) adverb points of the examples
    keytimes_table : (E, N) keytimes of the examples, seconds
    coefficients : (E, NumCP, D) B-spline control points of every DOF of every example
    encoding : DofEncoding (the skeleton is ``encoding.skeleton``)
    constraints : the kinematic constraints (feet held between keytimes)
    holds : how the planter holds each constraint's effector, in generic time, with the effector's
        height above the floor while down (measured from the examples' contacts at build; by default
        read from the constraints' keytimes alone)
    hold_table : (E, L, 3) each example's foot-flat, heel-off and toe-off of each hold, generic time
        after its opening (blended like keytimes: :meth:`hold_times`; default: the holds' own)
    floor : height of the ground the examples stand on, metres
    generic_keytimes : (N,) where each keytime sits in generic time, from 0 to 1, shared by every
        example (default: evenly spaced, the paper's; see :mod:`adverbs.interp.timewarp`)
    smoothing, shrinkage : the interpolation's smoothing λ and slope shrinkage μ (0: exact, the
        paper's; ``"auto"``: chosen by leave-one-out on the verb's own tables, then kept as numbers;
        see :class:`~adverbs.interp.rbf.AdverbInterpolator`)
    goal_chain : joints whose rotations put the joint of the verb's ``joint_position`` adverbs on the
        asked goal at their keytime (empty: no goal correction; see :mod:`adverbs.verb.goal`)
    timing : how keytime intervals behave past the examples: ``"extrapolate"`` (default, the paper's:
        each log interval is interpolated like any value, so a point past the quickest examples is
        quicker still) or ``"clamp"`` (each interval stays within the examples' shortest and longest for
        that interval: past the examples the motion goes further, never faster or slower than a take did)

    Derived tables (computed once): ``interpolator`` (cardinal weights), ``log_intervals (E, N-1)``,
    ``interval_bounds (2, N-1)`` (the smallest and largest log interval ``timing`` allows: ±∞ when it
    extrapolates), ``segments (NumCP, E, D)`` (the coefficients by control point, with the B-spline
    basis's 1/6 folded in: what the sampling kernel reads), ``seam_table (E, D)`` (each example's end value
    minus its start value, ``d(1) − d(0)``: the jump hidden where a cycle follows itself) and ``goal``
    (the :class:`~adverbs.verb.goal.Goal` of ``goal_chain``, or None).

    Past the examples (see :func:`follows`): ``follows (D,)`` says how much each DOF follows the adverbs outside the
    examples' convex hull, 1 (the paper's extrapolation) or 0 (held at the nearest point of the hull). A verb that
    holds some DOF samples with ``2E`` weights per creature, ``w(p)`` then ``w(h) − w(p)`` (``h`` the hull's point
    nearest ``p``; zeros inside the hull), and its ``segments (NumCP, 2E, D)`` and ``seam_table (2E, D)`` repeat the
    examples' with each DOF scaled by ``1 − follows``: one blend, ``v(p) + (1 − follows) (v(h) − v(p))``.
    ``weight_columns`` is ``E`` or ``2E``.
    """

    name: str
    encoding: DofEncoding
    adverbs: tuple[Adverb, ...]
    examples: tuple[ExampleRecord, ...]
    points: np.ndarray
    keytimes_table: np.ndarray
    coefficients: np.ndarray
    cyclic: bool
    fps: float
    keytime_names: tuple[str, ...] = ()
    constraints: tuple[Constraint, ...] = ()
    floor: float = 0.0
    generic_keytimes: np.ndarray | None = None
    smoothing: float | str = 0.0
    shrinkage: float | str = 0.0
    holds: tuple[Hold, ...] = ()
    hold_table: np.ndarray | None = None
    goal_chain: tuple[str, ...] = ()
    timing: str = "extrapolate"
    interpolator: AdverbInterpolator = field(init=False, repr=False)
    log_intervals: np.ndarray = field(init=False, repr=False)
    interval_bounds: np.ndarray = field(init=False, repr=False)
    segments: np.ndarray = field(init=False, repr=False)
    seam_table: np.ndarray = field(init=False, repr=False)
    follows: np.ndarray = field(init=False, repr=False)
    goal: Goal | None = field(init=False, repr=False)
    goal_misses: np.ndarray | None = field(init=False, repr=False)

    def __post_init__(self) -> None:
        name, enc = self.name, self.encoding
        put = object.__setattr__  # the dataclass is frozen: fields are set once, here
        put(self, "adverbs", tuple(self.adverbs))
        put(self, "examples", tuple(self.examples))
        put(self, "constraints", tuple(self.constraints))
        put(self, "points", _frozen(self.points))
        put(self, "keytimes_table", _frozen(timewarp.check_keytimes(self.keytimes_table, f"verb {name!r}")))
        put(self, "coefficients", _frozen(self.coefficients))
        put(self, "cyclic", bool(self.cyclic))
        put(self, "fps", float(self.fps))
        put(self, "floor", float(self.floor))
        n = self.keytimes_table.shape[1]
        try:
            put(self, "generic_keytimes", _frozen(timewarp.check_generic(self.generic_keytimes, n)))
        except AdverbsError as e:
            raise AdverbsError(f"verb {name!r}: {e}") from None
        put(self, "keytime_names", tuple(self.keytime_names) or tuple(f"keytime {i}" for i in range(n)))
        if len(self.keytime_names) != n:
            raise AdverbsError(f"verb {name!r}: {len(self.keytime_names)} keytime names for {n} keytimes")
        for c in self.constraints:
            check_constraint(c, enc.skeleton, n, self.cyclic)
        holds = tuple(self.holds) or tuple(default_holds(self.constraints, self.generic_keytimes, self.cyclic))
        if [h.effector for h in holds] != [c.effector for c in self.constraints]:
            raise AdverbsError(f"verb {name!r}: {len(holds)} holds for {len(self.constraints)} constraints")
        put(self, "holds", holds)
        spans = np.array([[h.toe_down - h.open, h.heel_off - h.open, h.close - h.open] for h in holds]).reshape(-1, 3)
        table = np.broadcast_to(spans, (len(self.examples),) + spans.shape) if self.hold_table is None else self.hold_table
        if np.shape(table) != (len(self.examples), len(holds), 3) or not np.all(np.isfinite(table)):
            raise AdverbsError(f"verb {name!r}: hold table {np.shape(table)} does not fit {len(holds)} holds")
        put(self, "hold_table", _frozen(table))
        e = len(self.examples)
        if self.points.shape != (e, len(self.adverbs)) or self.keytimes_table.shape[0] != e:
            raise AdverbsError(f"verb {name!r}: tables disagree on the number of examples or adverbs")
        coef = self.coefficients
        if coef.ndim != 3 or coef.shape[0] != e or coef.shape[2] != enc.num_dofs:
            raise AdverbsError(f"verb {name!r}: coefficient table {coef.shape} does not fit")
        bspline.check_num_cp(coef.shape[1])
        log_intervals = np.log(np.diff(self.keytimes_table, axis=1))
        ip = AdverbInterpolator(
            self.points,
            [x.name for x in self.examples],
            linear=[not x.refine for x in self.examples],
            smoothing=self.smoothing,
            shrinkage=self.shrinkage,
            # What "auto" cross-validates on; a fixed λ, μ (every loaded verb) needs no copy of the tables.
            values=np.concatenate([coef.reshape(e, -1), log_intervals], axis=1)
            if "auto" in (self.smoothing, self.shrinkage)
            else None,
        )
        put(self, "interpolator", ip)
        put(self, "smoothing", float(ip.smoothing))  # "auto" resolved: what a saved verb keeps
        put(self, "shrinkage", float(ip.shrinkage))
        put(self, "log_intervals", _frozen(log_intervals))
        if self.timing not in TIMINGS:
            raise AdverbsError(f"verb {name!r}: timing must be one of {', '.join(map(repr, TIMINGS))}, got {self.timing!r}")
        if self.timing == "clamp":
            bounds = np.array([log_intervals.min(axis=0), log_intervals.max(axis=0)])
        else:
            bounds = np.repeat([[-np.inf], [np.inf]], n - 1, axis=1)
        put(self, "interval_bounds", _frozen(bounds))
        follow = follows(self.adverbs, enc)
        put(self, "follows", _frozen(follow))
        segments = coef.transpose(1, 0, 2) / 6.0
        v0, _, v1, _ = bspline.ends(coef.transpose(1, 0, 2))
        seam = v1 - v0
        if (follow < 1.0).any():  # held DOFs: the examples again, scaled by how much each DOF is held
            segments = np.concatenate([segments, segments * (1.0 - follow)], axis=1)
            seam = np.concatenate([seam, seam * (1.0 - follow)], axis=0)
        put(self, "segments", _frozen(segments))
        put(self, "seam_table", _frozen(seam))
        put(self, "goal_chain", tuple(self.goal_chain))
        goal = None
        if self.goal_chain:
            try:
                goal = Goal.build(self.goal_chain, self.adverbs, enc, self.generic_keytimes, self.cyclic)
            except AdverbsError as e:
                raise AdverbsError(f"verb {name!r}: {e}") from None
        put(self, "goal", goal)
        put(self, "goal_misses", None if goal is None else _frozen(goals.misses(self)))

    def __repr__(self) -> str:
        kind = "cyclic" if self.cyclic else "one-shot"
        return (
            f"Verb({self.name!r}: {kind}, {len(self.examples)} examples, adverbs {', '.join(self.adverb_names)}; "
            f"{self.num_keytimes} keytimes, {self.num_dofs} DOFs x {self.num_cp} control points)"
        )

    # ----- shape -------------------------------------------------------------------------------
    @property
    def skeleton(self) -> Skeleton:
        return self.encoding.skeleton

    @property
    def num_cp(self) -> int:
        return self.coefficients.shape[1]

    @property
    def num_keytimes(self) -> int:
        return self.keytimes_table.shape[1]

    @property
    def num_dofs(self) -> int:
        return self.encoding.num_dofs

    @property
    def weight_columns(self) -> int:
        """How many blend weights a creature's sampling state keeps: ``E``, or ``2E`` when the verb holds DOFs past
        its examples (see :func:`follows`)."""
        return self.segments.shape[1]

    @property
    def adverb_names(self) -> tuple[str, ...]:
        return tuple(a.name for a in self.adverbs)

    def _example_samples(self, n: int) -> np.ndarray:
        """Each example's DOFs ``(E, n, D)`` at ``n`` evenly spaced generic times from 0 to 1 (its fitted curve)."""
        e, cp, d = self.coefficients.shape
        flat = self.coefficients.transpose(1, 0, 2).reshape(cp, e * d)
        return bspline.evaluate(flat, np.linspace(0, 1, n)).reshape(n, e, d).transpose(1, 0, 2)

    @cached_property
    def leg_chains(self) -> LegChains:
        """The two-bone chains of the constrained effectors, knee axes fitted to the examples.

        Derived from the tables alone, computed on first use and kept (it never changes).
        """
        if not self.constraints:
            raise AdverbsError(f"verb {self.name!r} has no constraints")
        rotations, _ = self.encoding.decode(self._example_samples(24), self.fps)
        effectors = [c.effector for c in self.constraints]
        return LegChains.build(self.skeleton, effectors, rotations.reshape(-1, *rotations.shape[-2:]))

    @cached_property
    def lift_table(self) -> np.ndarray:
        """Each example's effector heights over their contact heights, ``(3, E, LIFT_SAMPLES + 1, L)``: on the cycle
        before, the cycle and the cycle after (a cyclic verb's other cycles are shifted by their seam, as sampling
        shifts them), at generic times ``k / LIFT_SAMPLES``: how high each example lifts each foot at each moment (FK
        of the example's own DOFs, over the verb's floor; NaN for an effector that keeps the verb's height). The
        planter keeps a swinging foot no lower than these blended at a creature's adverbs
        (:func:`adverbs.feet.planter.example_lifts`).

        Derived from the tables alone, computed on first use and kept (it never changes).
        """
        from ..kinematics.fk import forward_kinematics  # (kinematics does not import verbs; kept local all the same)

        samples = self._example_samples(LIFT_SAMPLES + 1)
        shift = np.array(self.seam_table[: len(samples)])
        shift[:, :VELOCITIES] = 0.0  # (sampling shifts the pose's columns by the laps' seams, not the velocities)
        laps = np.stack([samples + lap * shift[:, None] for lap in (-1, 0, 1)])
        rot, trans = self.encoding.decode_pose(laps, np.zeros(3))
        pos, _ = forward_kinematics(self.skeleton.parents, rot, trans)
        tips, heights = self._effectors
        return _frozen(pos[..., tips, 1] - self.floor - heights)

    @cached_property
    def _effectors(self) -> tuple[list[int], np.ndarray]:
        """Each hold's effector joint and its contact height (NaN: an effector that keeps the verb's height)."""
        tips = [self.skeleton.index(c.effector) for c in self.constraints]
        return tips, _frozen(np.array([np.nan if h.height is None else h.height for h in self.holds]))

    def contact_levels(self, points: np.ndarray) -> np.ndarray:
        """Each foot's contact level ``(C, L)`` at adverb points ``(C, A)``: the lowest its effector comes over its
        contact height while the verb holds it (from the hold's opening to its toe-off), in the verb's own pose at
        those points, sampled (:meth:`dofs`, forward kinematics) at ``LEVEL_SAMPLES`` evenly spaced generic times of
        the hold: how far the verb's stance sits over or under the floor there. NaN for a one-shot verb and an
        effector that keeps the verb's height. What the planter takes a verb's level to be before it has stood a
        foot in it (``graph.planted``).

        The examples' foot heights blended with the points' weights (:attr:`lift_table`) are not the pose's: a blend
        of leg rotations puts the foot lower or higher than the blend of where the examples put it (8 mm over a CMU
        walk's at 1.5 m/s turning 25°/s). 16 samples are within 1.2 mm of 512 on both shipped graphs' walks and runs
        inside their examples; 25% past them a walk's foot dips for a moment, and 16 can miss up to 9 mm of it."""
        p = np.ascontiguousarray(np.atleast_2d(np.asarray(points, dtype=float)))
        c, n_l = len(p), len(self.holds)
        if not (self.cyclic and n_l and c):
            return np.full((c, n_l), np.nan)
        if c > 1:  # creatures at one point have one level (each row is its own): a crowd's shared points once
            unique, back = np.unique(p, axis=0, return_inverse=True)
            if len(unique) < c:
                return self.contact_levels(unique)[back.reshape(-1)]
        if c > LEVEL_BLOCK:  # a crowd in blocks: its poses stay in the cache (10,000 at once took 4x as long)
            return np.concatenate([self.contact_levels(p[a : a + LEVEL_BLOCK]) for a in range(0, c, LEVEL_BLOCK)])
        if not np.all(np.isfinite(p)):
            raise AdverbsError("adverb values must be finite numbers (got NaN or infinity)")
        if c == 1:  # one point: kept (a crowd at a few shared points asks for them again and again, ~1 ms a call)
            kept = self._levels_kept
            key = p.tobytes()
            if key not in kept:
                if len(kept) >= LEVELS_KEPT:
                    kept.clear()
                kept[key] = self._contact_levels(p)
            return kept[key].copy()
        return self._contact_levels(p)

    @cached_property
    def _levels_kept(self) -> dict[bytes, np.ndarray]:
        """:meth:`contact_levels` of single points already worked out, by the point's bytes."""
        return {}

    def _contact_levels(self, p: np.ndarray) -> np.ndarray:
        """:meth:`contact_levels` of finite points ``p (C, A)``, worked out."""
        from ..kinematics.fk import forward_kinematics  # (kinematics does not import verbs; kept local all the same)

        c, n_l = len(p), len(self.holds)
        w = sampling.point_weights(self, p)  # (each creature's own bits, alone or in a crowd)
        opens = np.array([h.open for h in self.holds])
        close = self.hold_times(w)[..., 2]  # (C, L): each hold's toe-off
        u = np.linspace(0.0, 1.0, LEVEL_SAMPLES)
        t = (opens[None, :, None] + (close - opens)[..., None] * u) % 1.0  # (C, L, K)
        dofs = sampling.generic_dofs(self, w, np.repeat(np.arange(c), n_l * LEVEL_SAMPLES), t.reshape(-1))
        rot, trans = self.encoding.decode_pose(dofs, np.zeros(3))
        parents = self.skeleton.parents
        tips, heights = self._effectors
        chain = sorted({a for j in tips for a in self.skeleton.ancestors(j)})  # FK of the root-to-feet joints alone
        at = {j: i for i, j in enumerate(chain)}
        pos, _ = forward_kinematics(np.array([at.get(parents[j], -1) for j in chain]), rot[:, chain], trans[:, chain])
        y = pos[:, [at[j] for j in tips], 1].reshape(c, n_l, LEVEL_SAMPLES, n_l)  # each foot's own: [:, l, :, l]
        own = np.stack([y[:, i, :, i] for i in range(n_l)], axis=1)  # (C, L, K)
        return own.min(axis=-1) - self.floor - heights

    @cached_property
    def root_velocity_samples(self) -> np.ndarray:
        """Each example's fitted root velocities ``(E, S, 3)`` (``root.vx``, ``root.vz``, ``root.turn``: sideways,
        forward, the heading's rate) at ``S = ACCELERATION_SAMPLES`` evenly spaced generic times from 0 to 1. Blended
        with a creature's weights they are its verb's root velocities there, exactly (the DOFs are linear in the
        weights): what :meth:`carry_limit` differentiates.

        Derived from the tables alone, computed on first use and kept (it never changes).
        """
        return _frozen(np.ascontiguousarray(self._example_samples(ACCELERATION_SAMPLES)[..., :3]))

    @cached_property
    def joint_speed_profile(self) -> np.ndarray:
        """How fast each example turns each joint through its generic time ``(E, S, J)``, rad/s of its own clock: the
        angle between its local rotations at ``S + 1 = SPEED_SAMPLES`` evenly spaced generic times, over the clock
        time between them. Blended with a creature's weights at each generic time (the examples are aligned there),
        its fastest is near the verb's own at the creature's adverbs (0.67-1.37x what its poses there show on the
        Bandai stand and gestures; the sad bow's trunk 1.03x, where the examples' fastest blended said 1.4x): how long
        a blend between standing verbs must be (``clocks.paced_length``).

        Derived from the tables alone, computed on first use and kept (it never changes).
        """
        rot, _ = self._speed_poses
        turn = quat.angle(rot[:, 1:], rot[:, :-1])
        return _frozen(turn / self._speed_steps[..., None])

    @cached_property
    def body_speed_profile(self) -> np.ndarray:
        """How fast each example moves its body root across the floor over its feet ``(E, S)``, m/s of its own clock,
        at :attr:`joint_speed_profile`'s times: the hips against the centre of the stance (:func:`body_place`), as a
        standing verb sways. A blend between standing verbs is paced by it too (``clocks.paced_length``).

        Derived from the tables alone, computed on first use and kept (it never changes).
        """
        from ..kinematics.fk import forward_kinematics  # (kinematics does not import verbs; kept local all the same)

        place = body_place(self.encoding, forward_kinematics(self.skeleton.parents, *self._speed_poses)[0])
        return _frozen(np.linalg.norm(np.diff(place, axis=1), axis=-1) / self._speed_steps)

    @cached_property
    def _speed_poses(self) -> tuple[np.ndarray, np.ndarray]:
        """Each example's local rotations and translations ``(E, S + 1, J, ·)`` at :attr:`joint_speed_profile`'s
        generic times (decoded at one root): what both speed profiles read."""
        return self.encoding.decode_pose(self._example_samples(SPEED_SAMPLES), np.zeros(3))

    @cached_property
    def _speed_steps(self) -> np.ndarray:
        """Each example's clock time between the generic times of :attr:`joint_speed_profile` ``(E, S)``."""
        generic = np.linspace(0.0, 1.0, SPEED_SAMPLES)
        return np.diff(np.stack([timewarp.clock_time(generic, k, self.generic_keytimes) for k in self.keytimes_table]))

    @cached_property
    def root_accelerations(self) -> np.ndarray:
        """Each example's fastest horizontal acceleration of its body root ``(E,)``, m/s², over its cycle in its own
        clock time, as a frame shows it (:meth:`carry_limit` at its own weight alone), at least ``SETTLING``. A
        walk's are 2-12 m/s². The carry's limit at a creature's adverbs is at most the fastest of these, and at least
        ``SETTLING``, so a body carried into a verb that does not travel (a stand in place: none of its own) still
        comes to rest: with a limit of nothing, a stop's last 4 cm/s went on through the stand's loop and ended in one
        frame (1.3 m/s²). (It was kept at least the slowest of these too: a run whose examples speed up at different
        times, blended, speeds up less than any of them, 5.9 m/s² at one point where the slowest example's is 8.1.)"""
        one = np.eye(len(self.examples))
        return _frozen(np.maximum(_fastest(self, one, self.keytimes_table), SETTLING))

    def carry_limit(self, weights: np.ndarray, keytimes: np.ndarray | None = None) -> np.ndarray:
        """The verb's own fastest root acceleration ``(...,)`` at cardinal ``weights (..., E)`` (and the ``keytimes
        (..., N)`` a sampling state keeps there; by default :meth:`keytimes`): the root velocities it plays there (its
        examples' :attr:`root_velocity_samples` blended), their change over a frame's step of its clock
        (:data:`FRAME`) with the heading's turn meanwhile (the body's acceleration in the world, as a frame shows
        it), at its fastest, at least ``SETTLING`` and at most the examples' fastest (:attr:`root_accelerations`).
        What a carried body's velocity may change by in a second (:func:`adverbs.graph.player.carry_limits`); it
        changes only with the weights, so a graph keeps each creature's once worked out, until its adverbs move
        (``clocks._carry``).

        It was each example's acceleration in its own clock, ``|v'| + |ω| |v|`` at 64 points of its cycle,
        blended: examples speeding up at different times, the turn's part added whatever its sense, and peaks
        shorter than a frame put a walk's limit up to 1.9x what the walk shows played at the point and a run's
        1.6x (now at most 1.09x at 24 random points: ``tests/test_edges.py``), so a start cut short and a walk → run
        carried the body at 1.5-1.6x their own."""
        acc = self.root_accelerations
        w = np.asarray(weights, dtype=float)[..., : len(acc)]
        if keytimes is None:  # row by row: a matrix product of many rows need not round as one row's does
            flat = w.reshape(-1, w.shape[-1])
            keytimes = np.array([self.keytimes(None, row) for row in flat]).reshape(w.shape[:-1] + (-1,))
        keys = np.asarray(keytimes, dtype=float)
        return np.clip(_fastest(self, w, keys), SETTLING, acc.max())

    def point(self, values: dict[str, float] | Sequence[float] | np.ndarray) -> np.ndarray:
        """An adverb point ``(A,)`` from a mapping of adverb names (missing ones: the examples' mean) or a sequence."""
        if isinstance(values, dict):
            unknown = set(values) - set(self.adverb_names)
            if unknown:
                raise AdverbsError(
                    f"verb {self.name!r} has no adverb {sorted(unknown)[0]!r}; adverbs are {', '.join(self.adverb_names)}"
                )
            p = self.points.mean(axis=0)
            for k, v in values.items():
                try:
                    p[self.adverb_names.index(k)] = v
                except (TypeError, ValueError):
                    raise AdverbsError(f"verb {self.name!r}: adverb {k!r} must be a number, got {v!r:.80}") from None
        else:
            try:
                p = np.array(values, dtype=float)
            except (TypeError, ValueError):
                raise AdverbsError(
                    f"verb {self.name!r}: an adverb point is {len(self.adverbs)} numbers ({', '.join(self.adverb_names)}) "
                    f"or a mapping of them, got {values!r:.80}"
                ) from None
        if p.shape[-1:] != (len(self.adverbs),):
            raise AdverbsError(f"verb {self.name!r} takes {len(self.adverbs)} adverbs, got {p.shape[-1:]}")
        if not np.all(np.isfinite(p)):
            bad = [self.adverb_names[i] for i in np.flatnonzero(~np.isfinite(p.reshape(-1, p.shape[-1])).any(0))]
            raise AdverbsError(f"adverb {bad[0]!r} must be a finite number")
        return p

    def outside(self, p: np.ndarray) -> np.ndarray:
        """How far ``p (..., A)`` lies outside the examples on each adverb, in ranges of the examples ``(..., A)``.

        0 inside the box the examples span; 0.25 a quarter of that adverb's range beyond its lowest
        or highest example. An adverb every example shares counts its distance in its own units.
        """
        p = np.asarray(p, dtype=float)
        lo, hi = self.points.min(axis=0), self.points.max(axis=0)
        span = np.where(hi > lo, hi - lo, 1.0)
        return np.maximum(np.maximum(lo - p, p - hi), 0.0) / span

    def clamp(self, p: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """``p`` moved into the examples' box, widened by ``margin`` ranges on each side."""
        if not (np.isfinite(margin) and margin >= 0):
            raise AdverbsError(f"clamp margin must be a number ≥ 0, got {margin}")
        lo, hi = self.points.min(axis=0), self.points.max(axis=0)
        span = hi - lo
        return np.clip(np.asarray(p, dtype=float), lo - margin * span, hi + margin * span)

    # ----- what depends on p alone ---------------------------------------------------------------
    def weights(self, p: np.ndarray) -> np.ndarray:
        """Cardinal weights ``(..., E)`` at adverb points ``(..., A)``."""
        return self.interpolator.weights(p)

    def blend(self, p: np.ndarray) -> np.ndarray:
        """The weights a sampling state keeps for adverb points ``(..., A)``, ``(..., weight_columns)``, by NumPy:
        :meth:`weights`, then, for a verb that holds DOFs past its examples, ``w(h) − w(p)`` at the point ``h`` of the
        examples' hull nearest ``p`` (zeros inside it; :func:`~adverbs.interp.rbf.hull_nearest_reference`)."""
        w = self.weights(p)
        if self.weight_columns == w.shape[-1]:
            return w
        ip = self.interpolator
        flat = np.asarray(p, dtype=float).reshape(-1, len(self.adverbs))
        held = np.zeros((len(flat), w.shape[-1]))
        for i, q in enumerate((flat - ip.centre) / ip.scale):
            h, dist = hull_nearest_reference(ip.kernel_tables[2], q)
            if dist > HULL_TOL:
                held[i] = ip.weights(h * ip.scale + ip.centre) - w.reshape(-1, w.shape[-1])[i]
        return np.concatenate([w, held.reshape(w.shape)], axis=-1)

    def keytimes(self, p: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
        """Keytimes ``(..., N)`` at ``p``: strictly increasing from 0 (see the module's keytime policy)."""
        w = self.weights(p) if weights is None else np.asarray(weights)[..., : len(self.examples)]
        steps = np.exp(np.clip(w @ self.log_intervals, *self.interval_bounds))
        bad = ~((steps > 0) & np.isfinite(steps)).all(axis=-1)
        if bad.any():  # so far out that an interval underflows to 0 s or overflows
            point = None if p is None else np.asarray(p, dtype=float).reshape(-1, len(self.adverbs))[int(np.argmax(bad.reshape(-1)))]
            raise sampling.degenerate(self, point, "a keytime interval would last 0 s or forever")
        return np.concatenate([np.zeros(steps.shape[:-1] + (1,)), np.cumsum(steps, axis=-1)], axis=-1)

    def hold_times(self, weights: np.ndarray) -> np.ndarray:
        """Generic times ``(..., L, 3)`` of each hold's foot-flat, heel-off and toe-off at cardinal ``weights (..., E)``.

        The examples' own, blended; kept in order (foot-flat ≤ heel-off ≤ toe-off, a cycle at most) where
        extrapolated weights would cross them.
        """
        # einsum's own loop, not BLAS: a creature's times are then the same bits alone or in a crowd (BLAS sums a
        # product of one row otherwise than of many, and a dataset's clip must not depend on its neighbours)
        w = np.asarray(weights, dtype=float)[..., : len(self.examples)]  # a state's held part moves no foot's timing
        spans = np.einsum("...e,elk->...lk", w, self.hold_table)
        opens = np.array([h.open for h in self.holds])
        close = np.clip(spans[..., 2], 1e-6, 1.0 if self.cyclic else None)
        if not self.cyclic:
            close = np.minimum(close, 1.0 - opens)
            close = np.where(self.hold_table[..., 2].min(axis=0) >= 1.0 - opens - 1e-9, 1.0 - opens, close)
        heel = np.clip(spans[..., 1], 0.0, close)
        flat = np.clip(spans[..., 0], 0.0, heel)
        return opens[:, None] + np.stack([flat, heel, close], axis=-1)

    def control_points(self, p: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
        """All control points ``(..., NumCP, D)`` at ``p`` (eq. 3, with DOFs held past the examples' hull as sampled);
        ``weights`` (:meth:`weights` or :meth:`blend`) if already known."""
        w = self.blend(p) if weights is None else np.asarray(weights, dtype=float)
        return np.tensordot(w, self.segments.transpose(1, 0, 2)[: w.shape[-1]] * 6.0, axes=(-1, 0))

    def playing(
        self, control_points: np.ndarray, keytimes: np.ndarray, p: np.ndarray | None = None, name: str = ""
    ) -> Verb:
        """A one-example verb that plays curves ``control_points (NumCP, D)`` at ``keytimes (N,)`` whatever its adverbs:
        another interpolator's prediction at adverb point ``p``, played by everything a verb is played by.

        Its encoding, constraints and holds are this verb's (the holds' times those at ``p``); its one example
        stands at ``p`` (default: the examples' mean). It has no goal chain: the curves are played as given.
        """
        p = self.point(self.points.mean(axis=0) if p is None else p)
        cp, k = np.asarray(control_points, dtype=float), np.asarray(keytimes, dtype=float)
        if cp.shape != (self.num_cp, self.num_dofs) or k.shape != (self.num_keytimes,):
            raise AdverbsError(f"verb {self.name!r}: control points {cp.shape} and keytimes {k.shape} do not fit it")
        opens = np.array([h.open for h in self.holds]).reshape(-1, 1)
        spans = self.hold_times(self.weights(p)) - opens
        name = name or self.name
        return dataclasses.replace(
            self, name=name, examples=(ExampleRecord(name, "", ""),), points=p[None], keytimes_table=k[None],
            coefficients=cp[None], hold_table=spans[None], smoothing=0.0, shrinkage=0.0, goal_chain=(),
        )  # fmt: skip

    def duration(self, p: np.ndarray) -> float:
        """Clock duration ``K_N(p)`` of one cycle (or of the whole motion) at one point ``p (A,)``."""
        return float(self.keytimes(self.point(p))[-1])

    # ----- evaluation: thin calls of the one sampling kernel --------------------------------------
    def state(self, creatures: int = 1, root: np.ndarray | None = None) -> sampling.SamplingState:
        """A fresh :class:`~adverbs.verb.sampling.SamplingState` for ``creatures`` creatures of this verb."""
        return sampling.SamplingState.new(self, creatures, root)

    def sample(
        self, points: np.ndarray, clocks: np.ndarray, state: sampling.SamplingState | None = None
    ) -> tuple[np.ndarray, sampling.SamplingState]:
        """DOFs ``(C, D)`` of C creatures at adverb points ``(C, A)`` and clock times ``(C,)``; see :func:`~adverbs.verb.sampling.sample`."""
        return sampling.sample(self, points, clocks, state)

    def pose(self, p: np.ndarray, clock: float, state: sampling.SamplingState | None = None) -> np.ndarray:
        """DOFs ``(D,)`` of one creature at ``p (A,)`` and clock time ``clock`` seconds; see :func:`~adverbs.verb.sampling.pose`."""
        return sampling.pose(self, p, clock, state)

    def dofs(self, p: np.ndarray, t: np.ndarray) -> np.ndarray:
        """DOFs ``(Q, D)`` at adverb points ``(Q, A)`` and generic times ``(Q,)``; see :func:`~adverbs.verb.sampling.dofs`."""
        return sampling.dofs(self, p, t)

    def synthesize(
        self,
        p: np.ndarray,
        duration: float | None = None,
        cycles: float | None = None,
        fps: float | None = None,
        start: Sequence[float] = (0.0, 0.0, 0.0),
    ) -> tuple[Clip, np.ndarray]:
        """A clip at ``p`` and its keytimes ``(N,)``; see :func:`~adverbs.verb.synthesis.synthesize`."""
        return synthesis.synthesize(self, p, duration, cycles, fps, start)


def body_place(encoding: DofEncoding, positions: np.ndarray) -> np.ndarray:
    """Where the body root stands over the feet ``(..., 2)``: its position across the floor (x, z) less the centre of
    the stance (the ankles' and toes' mean), for global joint ``positions (..., J, 3)``; the body root's own where the
    skeleton shows no feet."""
    stance = stance_joints(encoding.skeleton) or [encoding.body_root]
    return (positions[..., encoding.body_root, :] - positions[..., stance, :].mean(axis=-2))[..., [0, 2]]


def follows(adverbs: Sequence[Adverb], encoding: DofEncoding) -> np.ndarray:
    """How much each DOF ``(D,)`` follows the adverbs past the examples: 1 for a DOF an adverb asks for, 0 for one held
    at the examples' hull.

    An adverb measured as a joint's position (``joint_position``: the reach's hand) asks for the rotations of the
    joints between the body root and that joint, the chain that moves it; one read off the root's path (speed, turn)
    or given by hand (a mood, a style) asks for the whole body. A DOF no adverb asks for — the reach's legs, root,
    other arm and head — still varies across the examples with the adverbs (the takes' styles move the hand and the
    stance together: the reach's leg DOFs fit the hand's position with R² 0.4-0.8, more than a walk's legs fit its
    speed and turn, 0.2-0.5), but nothing asks it to go on past them: there it is held where the examples' hull
    leaves it.
    """
    d = encoding.num_dofs
    skel = encoding.skeleton
    asked: set[int] = set()
    for a in adverbs:
        m = a.measure or {}
        if m.get("kind") != "joint_position" or m.get("joint") not in skel.names:
            return np.ones(d)
        j = skel.parents[skel.names.index(m["joint"])]
        while j >= 0 and j != encoding.body_root:
            asked.add(int(j))
            j = skel.parents[j]
        if j < 0:  # the joint is not below the body root: the whole body moves it
            return np.ones(d)
    prefixes = tuple(f"{skel.names[j]}." for j in asked)
    return np.array([1.0 if n.startswith(prefixes) else 0.0 for n in encoding.names])


def _fastest(verb: Verb, weights: np.ndarray, keytimes: np.ndarray) -> np.ndarray:
    """The fastest root acceleration ``(...,)`` of ``verb`` played at ``weights (..., E)`` and ``keytimes (..., N)``
    over a frame (see :meth:`Verb.carry_limit`): from each of its :attr:`~Verb.root_velocity_samples`' generic times
    to :data:`FRAME` seconds of its clock later (the velocities there linear between the samples' clock times), the
    later velocity turned by the heading's change meanwhile (at the two velocities' mean rate). Its last frame's
    worth of clock is not a start: a cycle's change across its seam into the next (which its loop's blend
    shows) is not read."""
    v = np.einsum("...e,esk->...sk", weights, verb.root_velocity_samples)  # einsum's own loop: alone = in a crowd
    flat_v, flat_k = v.reshape(-1, *v.shape[-2:]), np.asarray(keytimes, dtype=float).reshape(-1, keytimes.shape[-1])
    generic = np.linspace(0.0, 1.0, ACCELERATION_SAMPLES)
    out = np.zeros(len(flat_v))
    for i, (vel, keys) in enumerate(zip(flat_v, flat_k, strict=True)):
        clock = timewarp.clock_time(generic, keys, verb.generic_keytimes)
        later = clock + FRAME
        later = later[later <= clock[-1]]
        if not len(later):
            continue
        now = vel[: len(later)]
        vx, vz, turn = (np.interp(later, clock, vel[:, k]) for k in range(3))
        angle = 0.5 * (now[:, 2] + turn) * FRAME
        c, s = np.cos(angle), np.sin(angle)
        out[i] = np.max(np.hypot(vx * c + vz * s - now[:, 0], vz * c - vx * s - now[:, 1])) / FRAME
    return out.reshape(v.shape[:-2])
