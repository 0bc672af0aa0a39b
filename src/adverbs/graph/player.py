"""Creatures moving through a verb graph, one frame at a time (§5): the readable reference of the frame.

:func:`step` advances C creatures by ``dt`` seconds; their progress lives in a :class:`GraphState` the
caller owns (the graph is shared and never changes). Each creature plays one verb instance — a verb
and a generic time ``g`` in it — or is in a transition from one instance (A) to another (B):

* **The queue.** Each creature holds the transitions still to take. A command (:func:`command`) puts
  there the path with the fewest transitions from the verb playing (or, during a transition, the one
  being entered) to the verb asked for. It never runs dry: when it empties, a transition away from the
  verb playing is drawn by likelihood from the creature's own seeded generator.
* **When a transition starts.** When the verb reaches the start of the next transition's region in it
  (``t_s^A``). A cyclic verb whose next region has already gone by in this cycle first takes its loop
  into itself; a one-shot verb already past it starts the transition at once, from where it is, and what is
  left of its region blends into the whole of B's, which plays no faster than its own clock (a gesture begun
  from a stand cut short used to start part-way through its raise, in a blend of 0.13-0.23 s, and pop the arm).
* **Cosine blend (the paper's).** It lasts the mean of the two regions' lengths in clock time at the
  current adverbs; ``β`` runs linearly from 0 to 1, each verb's clock runs through its region (so its
  root velocities are scaled by how much faster or slower that makes it), and with
  ``α = 0.5 cos(βπ) + 0.5`` every joint rotation is ``slerp(θ^B, θ^A, α)`` — on the rotations
  themselves, so verbs fitted with different DOF encodings blend correctly — and the root's
  velocities (sideways, forward, turning) and height are ``α A + (1 − α) B``, then integrated.
* **Inertial blend, and interruption.** An inertial transition plays B at once; the difference
  between the pose shown and B's (and between their velocities) becomes an offset that decays as a
  critically damped spring (half-life ``duration · INERTIAL_HALFLIFE``). A command during an
  interruptible transition: back to the cycle being left, the blend turns back (both verbs play on,
  the weight climbs back by the same cosine law); otherwise B plays on alone from the pose shown (an
  offset, half-life at least ``INTERRUPT_HALFLIFE``) and the new path starts from B — at once, and
  inertially, when B is a one-shot verb whose way on is already open. A stop (a cycle blending into a
  one-shot) is not cut short: the new path starts from B once the stop has put its feet down.
* **The upper body past a short blend.** A cosine blend into a cycle (a walk into a run, over the quarter cycle
  their feet agree on; a stand into a walk) shorter than ``ARMS_BLEND`` plays the upper body (``Graph.carried``: the
  trunk above the hips, the head, the arms) of B at once, the pose shown's difference from them fading to nothing
  ``ARMS_BLEND`` on (:func:`_arms`): the legs keep the blend's timing, a forearm bent 80° more in the run no longer
  turns at 3.3x its verbs' own, and a start's chest and head no longer turn at 1.5-1.7x. A stop (a cycle into a
  one-shot) carries the upper body the same way over its own blend.
* **Feet.** In a cosine blend a foot is held where both verbs hold it, where A does and still has the weight,
  or where B does and A has begun to land it (:func:`hold_phases`). Blending two stances would slide a held
  foot, so the body is carried by the held feet's slip instead (:func:`_keep_feet`). :class:`GraphFeet` re-places a foot a
  verb playing alone has somewhere else (``REPLANT``).
* **Cycles.** A cyclic verb instance plays one cycle; its loop into itself is a transition like any
  other. Where a target region ends at the end of a cyclic verb's cycle, B plays that region as the
  end of the *previous* cycle (the seam ``d(1) − d(0)`` taken off), so it goes on into its next cycle
  without a jump.
* **The root** is integrated from the blended velocities, so every verb instance starts where the
  creature is, facing where it faces: a walk looping into itself keeps walking on, turns accumulate.

Each frame also gives, for every constrained foot, whether it is held (held in both verbs of a blend;
released by either, released) and how far it has rolled off, for a planter (:mod:`.planted`).

The state and its queues are :mod:`.state`, the discrete decisions :mod:`.queue`, the time warps and the
transitions' clocks :mod:`.clocks`; this module is the continuous frame, NumPy over creatures. The run time steps
the same frame as one compiled pass (:mod:`adverbs.runtime.frame`), which a test holds to this one.
"""


from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import AdverbsError
from ..kinematics import quat
from ..verb._sampling_kernel import GENERIC, VELOCITIES
from ..motion._pose_kernel import blend_poses, root_velocities
from ..motion.encoding import advance_root
from ..feet.planter import SWING_LIFT, _spring, example_lifts
from ..verb.sampling import run_kernel
from ._blend_kernel import decay_offsets, keep_feet
from ._time_kernel import hold_rows
from .structure import Graph
from .clocks import _by_verb, _carry, _clock, _generic, _hold_times, _later, _place, _rates, _sampling, blend_weight
from .queue import _finish, _start
from .state import _LATE, GraphState

LANDS = 1.0  # a foot B holds and A swings lands once A's swing lift is below this: as soon as A begins to land it


@dataclass
class Frame:
    """One frame of C creatures: local ``rotations (C, J, 4)``, ``translations (C, J, 3)``, the ``root (C, 3)``,
    the root's velocities ``(C, 3)`` (sideways, forward m/s, turn rad/s), and per foot of the graph's feet
    ``held (C, L)``, ``roll (C, L)``, ``swing (C, L)`` and ``lifts (C, L)`` (see :func:`hold_phases`); the verbs
    shown, ``verbs (C, 2)`` (A and B; A twice where a creature plays one verb), A's weight ``alpha (C,)`` and the
    share ``eased (C,)`` of the examples' lifts a decaying offset leaves the planter (1 without one: :func:`_eased`)."""

    rotations: np.ndarray
    translations: np.ndarray
    root: np.ndarray
    velocity: np.ndarray
    held: np.ndarray
    roll: np.ndarray
    swing: np.ndarray
    lifts: np.ndarray
    verbs: np.ndarray
    alpha: np.ndarray
    eased: np.ndarray


def feet(graph: Graph) -> list[int]:
    """The effector joints any verb of the graph holds, in the order the first such verb lists them."""
    return list(graph.feet)



def _advance(state: GraphState, dt: float) -> None:
    """Move every creature's times on by ``dt``: verbs playing alone by their own clocks, transitions by ``β``."""
    graph = state.graph
    c_all = np.arange(state.creatures)
    moving = c_all[state.active >= 0]
    state.beta[moving] += dt / state.length[moving]
    alone = c_all[state.active < 0]
    if len(alone):
        g_new = _later(state, state.verb, state.g[alone], dt, 0, alone)
        nxt = np.array([graph.transitions[state.queue[c][0]].source_region[0] for c in alone])
        begins = g_new >= nxt - _LATE
        one_shot = ~graph.cyclic[state.verb[alone]]
        g_new = np.where(one_shot, np.minimum(g_new, 1.0), g_new)
        for i in np.flatnonzero(begins):
            c = int(alone[i])
            # How much of this frame is left after the region's start (none if it had gone by).
            row = np.array([c])
            clock = _clock(state, state.verb, state.g[row], 0, row)[0] + dt
            at = float(_clock(state, state.verb, np.array([max(nxt[i], state.g[c])]), 0, row)[0])
            state.g[c] = max(nxt[i], min(state.g[c], 1.0))
            _start(state, c, max(float(clock) - at, 0.0))
        rest = ~begins
        state.g[alone[rest]] = g_new[rest]
    for c in moving[state.beta[moving] >= 1.0]:  # transitions ending this frame
        over = (state.beta[c] - 1.0) * state.length[c]
        state.beta[c] = 1.0
        _place(state, np.array([c]))
        _finish(state, int(c))
        if over > 0:  # the rest of the frame, B alone
            row = np.array([c])
            state.g[c] = _later(state, state.verb, state.g[row], over, 0, row)[0]
    _place(state, c_all[state.active >= 0])



def _dofs(state: GraphState, verbs: np.ndarray, g: np.ndarray, slot: int, rows: np.ndarray) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """DOFs of each verb at generic times ``g (C,)`` for the creatures ``rows``: verb → (its rows, DOFs (n, D))."""
    out = {}
    for v, which in _by_verb(verbs, rows):
        sel = rows[which]
        verb = state.graph.verbs[v]
        s = _sampling(state, v, slot)
        # A one-shot's generic time is its own, 0 to 1: at its end (g = 1, where it waits for its next transition)
        # it shows its last pose. Taken as a lap, it showed its first, and its root its first velocity: a stand that
        # gesture → stand left at its end snapped to its start pose, and its body stopped, in one frame.
        lap = np.floor(g[sel]) if verb.cyclic else np.zeros(len(sel))
        local = np.clip(g[sel] - lap, 0.0, 1.0)
        d = run_kernel(verb, s, sel, local, GENERIC)
        if verb.cyclic:  # the pose of another cycle: shifted by the seam (the velocities: see _sample)
            d[:, VELOCITIES:] += lap[:, None] * s.seam[sel, VELOCITIES:]
        out[v] = (sel, d)
    return out


@dataclass
class _Base:
    """What the verbs give every creature at one time, before offsets: DOFs by slot and verb, the blend weight
    ``alpha (C,)`` of A (1 alone, 0 inertial), and the blended root velocities ``(C, 3)``."""

    a: dict
    b: dict
    alpha: np.ndarray
    velocity: np.ndarray


def _sample(state: GraphState, g_a: np.ndarray, g_b: np.ndarray) -> _Base:
    c_all = np.arange(state.creatures)
    moving = c_all[state.active >= 0]
    inertial = (state.active >= 0) & state.inertial
    rate_a, rate_b, alpha = np.ones(state.creatures), np.ones(state.creatures), np.ones(state.creatures)
    b = {}
    if len(moving):
        rate_a[moving], rate_b[moving] = _rates(state, moving)
        # A one-shot with nothing of its region left (waiting at its end: a stand a gesture → stand brought there)
        # stands still in the pose it ends on, but its body goes on at its own last velocity, as its clock would run,
        # fading with its weight. With its clock's rate (0), the body took B's way at once: at the start of a reach
        # from a stand's end it turned back on itself in one frame (0.9 m/s², the reach's own 0.15).
        one_shot = ~state.graph.cyclic[state.verb[moving]]
        rate_a[moving[(state.regions[moving, 0] == state.regions[moving, 1]) & one_shot]] = 1.0
        alpha[moving] = np.where(inertial[moving], 0.0, blend_weight(state.beta[moving]))
        b = _dofs(state, state.into, g_b, 1, moving)
    a = _dofs(state, state.verb, g_a, 0, c_all[~inertial])
    vel = np.zeros((state.creatures, 3))
    for sel, d in a.values():
        vel[sel] += (alpha[sel] * rate_a[sel])[:, None] * d[:, :3]
    for v, (sel, d) in b.items():
        vel[sel] += ((1.0 - alpha[sel]) * rate_b[sel])[:, None] * d[:, :3]
        # B playing its previous cycle: its velocities' seam is taken off by a weight that rises from 0 to 1 and
        # integrates to zero, so the blend ends on B's next cycle without adding distance or turn (the sampling
        # kernel's seam fade, run backwards).
        prev = sel[g_b[sel] < 0.0]
        if len(prev):
            u = _seam_rise(state.beta[prev])
            vel[prev] -= (u * rate_b[prev])[:, None] * _sampling(state, v, 1).seam[prev, :VELOCITIES]
    return _Base(a, b, alpha, vel)


def _seam_rise(beta: np.ndarray) -> np.ndarray:
    """``1 − (1 − β)²(1 + 2β) − 3β(1 − β)``: 0 at ``β = 0``, 1 at ``β = 1``, zero integral over ``[0, 1]``."""
    return 1.0 - (1.0 - beta) ** 2 * (1.0 + 2.0 * beta) - 3.0 * beta * (1.0 - beta)


def _decoded(state: GraphState, slot: dict, root: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Local rotations and translations of the creatures of one slot of a :class:`_Base` (``{verb: (rows, DOFs)}``)
    at ``root (C, 3)`` (other rows unset)."""
    j, n = state.graph.skeleton.num_joints, state.creatures
    rot, trans = np.empty((n, j, 4)), np.empty((n, j, 3))
    for v, (sel, d) in slot.items():
        state.graph.verbs[v].encoding.decode_into(d, root[sel], sel, rot, trans)
    return rot, trans


def _decode(state: GraphState, base: _Base, root: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Local rotations and translations of every creature at ``root (C, 3)``: A and B decoded, then blended by
    ``alpha`` on the rotations (slerp) and translations (linearly); and B's rotations alone (None without B)."""
    rot, trans = _decoded(state, base.a, root)
    rot_b = None
    if base.b:
        rot_b, trans_b = _decoded(state, base.b, root)
        r = np.flatnonzero(state.active >= 0)
        blend_poses(rot, trans, rot_b, trans_b, r, np.ascontiguousarray(base.alpha[r]))
    return rot, trans, rot_b


def _back(state: GraphState, rows: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Generic times of A and B ``dt`` seconds ago by their clocks, for the creatures ``rows`` (others: now)."""
    g_a, g_b = state.g.copy(), state.g_into.copy()
    rate_a, rate_b = np.ones(state.creatures), np.ones(state.creatures)
    t = rows[state.active[rows] >= 0]
    if len(t):
        rate_a[t], rate_b[t] = _rates(state, t)
        g_b[t] = _generic(state, state.into, _clock(state, state.into, state.g_into[t], 1, t) - dt * rate_b[t], 1, t)
    g_a[rows] = _generic(state, state.verb, _clock(state, state.verb, state.g[rows], 0, rows) - dt * rate_a[rows], 0, rows)
    return g_a, g_b


def _relative(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation vectors of ``a b⁻¹`` (the short way round)."""
    q = quat.mul(a, quat.inv(b))
    return quat.log(np.where(q[..., 3:] < 0.0, -q, q))


def step(state: GraphState, dt: float) -> Frame:
    """Advance every creature by ``dt`` seconds; the frame they show."""
    dt = float(dt)
    if not (math.isfinite(dt) and dt > 0):
        raise AdverbsError(f"dt must be a positive number of seconds, got {dt}")
    state.fresh = set()  # the sampling caches brought up to date once in this step (see _sampling)
    state.regions_seen = {}  # and the transitions' region clocks, once per step (see _region_clocks)
    try:
        return _step(state, dt)
    finally:
        state.fresh = state.regions_seen = None


def _step(state: GraphState, dt: float) -> Frame:
    state.time += dt
    if state.moving is None:  # the first step without a first frame: the velocities where the creatures start
        state.moving = _sample(state, state.g, state.g_into).velocity
    _advance(state, dt)
    base = _sample(state, state.g, state.g_into)
    rows = np.flatnonzero(state.rebase)
    state.rebase[:] = False
    before = None
    if len(rows) and state.shown is not None:
        # Carry on from what was shown: the offset is (shown − verbs) a frame ago, its velocity the difference
        # of their velocities since.
        before = _sample(state, *_back(state, rows, dt))
        state.offset_root[rows] = state.moving[rows] - before.velocity[rows]
    vel = base.velocity.copy()
    state.offset_since += dt
    if before is not None:
        state.offset_since[rows] = dt  # the offset was taken a frame ago, at what was shown then
    live = np.flatnonzero(state.offset_since < 12.0 * state.offset_halflife)
    if len(live):
        t, h = state.offset_since[live, None], state.offset_halflife[live, None]
        vel[live] += _spring(state.offset_root[live], 0.0, t, h)
    # The root moves at the velocities of the step's start, as a clip's velocity columns say (a frame's velocity is
    # its step to the next): a verb playing alone travels exactly as its synthesized clip does.
    new_root = advance_root(state.root, state.moving, dt)
    # ... and so does a body carried by its feet (_keep_feet): at the speed of the step's start. Held to the speed
    # at its end, the first step of a blend skipped a frame's change and its last repeated one: a stop begun as the
    # walk slowed after a heel strike went 1.88 -> 1.51 m/s in a frame (11 m/s², the walk's own 6).
    step_speed = np.hypot(state.moving[:, 0], state.moving[:, 1])
    _at_blend_speed(state, vel, _speeds(state, base, vel))
    state.moving = vel
    rot, trans, rot_b = _decode(state, base, new_root)
    if before is not None:
        rot0, trans0, _ = _decode(state, before, state.root)
        s_rot, s_trans, _ = state.shown
        state.offset_rot[rows] = _relative(s_rot[rows], rot0[rows])
        state.offset_trans[rows] = s_trans[rows] - trans0[rows]
        state.offset_rot_vel[rows] = 0.0
        state.offset_trans_vel[rows] = 0.0
        if state.shown_before is not None:
            b_rot, b_trans, _ = state.shown_before
            state.offset_rot_vel[rows] = (_relative(s_rot[rows], b_rot[rows]) - _relative(rot[rows], rot0[rows])) / dt
            state.offset_trans_vel[rows] = ((s_trans[rows] - b_trans[rows]) - (trans[rows] - trans0[rows])) / dt
        # The root's own travel is the root's (offset_root): the body root carries an offset only for where the verbs
        # stand it off the root and how fast that changes (an anchored verb's hips swaying over its feet,
        # DofEncoding.anchored; none for a verb whose root is its hips).
        if state.shown_before is not None:
            _body_off_root(state, rows, new_root, dt)
    if len(live):
        decay_offsets(
            live, state.offset_since[live], state.offset_halflife[live], state.offset_rot, state.offset_rot_vel,
            state.offset_trans, state.offset_trans_vel, rot, trans,
        )  # fmt: skip
    _arms(state, rot, rot_b, rows if before is not None else rows[:0], dt)
    held, roll, swing, lifts = hold_phases(state)
    blended = np.zeros(state.creatures, dtype=bool)
    blended[live] = True
    eased = np.ones(state.creatures)
    if len(live):  # the examples' lifts kept under the foot as much as the pose shown has become the verbs'
        eased[live] = _eased(state.offset_since[live], state.offset_halflife[live])
    # One verb (alone, or looping into itself: its instances keep their feet alike) and no decaying offset.
    state.alone = ((state.active < 0) | ~state.graph.between_verbs[state.active]) & ~blended
    state.standing = _standing(state)
    new_root = _keep_feet(state, rot, trans, new_root, held, roll, blended, step_speed, dt)
    vel = _velocity(state.root, new_root, dt)
    state.root = new_root
    state.shown_before, state.shown = state.shown, (rot, trans, vel)
    state.held_before = held
    return Frame(rot, trans, new_root.copy(), vel, held, roll, swing, lifts, _verbs(state), base.alpha.copy(), eased)


def _arms(state: GraphState, rot: np.ndarray, rot_b: np.ndarray | None, rebased: np.ndarray, dt: float) -> None:
    """The upper body (``Graph.carried``; the state's ``arms_*``, named for them) carried past a short blend into a
    cycle (over ``ARMS_BLEND``) and through a stop (over its blend), onto the rotations ``rot (C, J, 4)`` in place;
    ``rot_b``: B's own (None without B); ``rebased``: the creatures whose whole pose took an offset this frame (it
    carries the arms' on: theirs ends).

    Where the blend starts (and where it is turned back), the difference between the pose shown a frame ago and B's
    then is taken (``x₀``, rotation vectors of the arms' joints) with the difference of their velocities since
    (``v₀``), as an interruption's offset is. Through that blend the arms play B, and until ``T`` after it was taken
    (``arms_length``) they show ``exp(o(t))`` before the verbs' rotations, ``o(t) = w(t / T) x₀ + v₀ t
    (1 − t / T)³`` with ``w(u) = ½ cos(π u) + ½``: the pose shown and its velocity at the start, none of it (and no
    velocity) at ``T``. A walk → run's forearm bending 80° in a 0.19 s blend turned at 3.3x its verbs' own; now
    0.8-1.0x. Through a stop the arms no longer swing on with the walk's weight while drawn to the stand's: a stop's
    upper arm turned at 1.63x the walk's own, now 1.26x.
    """
    carried, arms = state.graph.carried, len(state.graph.arms)
    state.arms_since += dt
    state.arms_since[rebased] = np.inf
    take = np.flatnonzero(state.arms_take & (state.active >= 0))
    # A blend turned back and over within the frame (a stop turned back into the walk the frame after it began): the
    # offset is taken again against the verb it went back to, playing alone (against the stand's arms, shown on the
    # walk's, it threw a hand 27 cm in a frame, 6.8x the walk's own). A blend begun and over within a frame with no
    # offset alive: none.
    alone = np.flatnonzero(state.arms_take & (state.active < 0) & (state.arms_since < state.arms_length))
    state.arms_take[:] = False
    for rows, slot in ((take, 1), (alone, 0)):
        if not (len(rows) and state.shown is not None and len(carried)):
            continue
        up = carried  # all of it taken (shown below: the arms alone, unless it carries the whole upper body)
        # B (A, alone) a frame ago, by its clock (player._back), and now.
        g_a, g_b = _back(state, rows, dt)
        verbs, g, now = (state.into, g_b, rot_b) if slot else (state.verb, g_a, rot)
        was, _ = _decoded(state, _dofs(state, verbs, g, slot, rows), state.root)
        shown = state.shown[0][rows][:, up]
        then = was[rows][:, up]
        state.arms_rot[rows] = _relative(shown, then)
        state.arms_vel[rows] = 0.0
        if state.shown_before is not None:
            state.arms_vel[rows] = (_relative(shown, state.shown_before[0][rows][:, up]) - _relative(now[rows][:, up], then)) / dt
        state.arms_since[rows] = dt
        state.arms_of[rows] = state.active[rows]
        # The whole pose's offset still decaying (a cut-short blend, an interruption) is in the pose shown, so in this
        # one: on the joints it shows (the arms, or the whole upper body) it is handed to it (kept there, it came back
        # in one frame as the blend that took this ended and the verb entered played alone, a hand at 19.6 rad/s).
        for upper in (False, True):
            shows = rows[state.arms_upper[rows] == upper]
            state.offset_rot[shows[:, None], carried[: len(carried) if upper else arms]] = 0.0
            state.offset_rot_vel[shows[:, None], carried[: len(carried) if upper else arms]] = 0.0
    live = np.flatnonzero(state.arms_since < state.arms_length)
    for upper in (False, True):  # the arms alone, or the whole upper body (a start)
        rows = live[state.arms_upper[live] == upper]
        if len(rows) == 0:
            continue
        n = len(carried) if upper else arms
        up = carried[:n]
        own = rows[(state.active[rows] >= 0) & (state.active[rows] == state.arms_of[rows])]  # in the blend that took it
        if len(own):
            rot[own[:, None], up] = rot_b[own[:, None], up]
        t = state.arms_since[rows, None, None]
        u = t / state.arms_length[rows, None, None]
        o = (0.5 * np.cos(np.pi * u) + 0.5) * state.arms_rot[rows, :n] + state.arms_vel[rows, :n] * t * (1.0 - u) ** 3
        rot[rows[:, None], up] = quat.mul(quat.exp(o), rot[rows[:, None], up])


def first_frame(state: GraphState) -> Frame:
    """The frame the creatures show where they start, before any :func:`step`: time 0 of a recording.

    Nothing moves: each verb is sampled where it stands, the root where it was put; the next :func:`step`
    carries on from this frame as from any other shown.
    """
    if np.any(state.time != 0.0):
        raise AdverbsError("first_frame: the creatures have already moved (it is the frame before any step)")
    base = _sample(state, state.g, state.g_into)
    rot, trans, _ = _decode(state, base, state.root)
    held, roll, swing, lifts = hold_phases(state)
    state.alone = (state.active < 0) | ~state.graph.between_verbs[state.active]
    state.standing = _standing(state)
    state.moving = base.velocity.copy()
    state.shown, state.held_before = (rot, trans, base.velocity.copy()), held
    return Frame(rot, trans, state.root.copy(), base.velocity.copy(), held, roll, swing, lifts, _verbs(state),
                 base.alpha.copy(), np.ones(state.creatures))  # fmt: skip


def _verbs(state: GraphState) -> np.ndarray:
    """``(C, 2)``: the verb each creature plays (A) and the one it blends into (B; A where it plays one)."""
    return np.stack([state.verb, _entering(state)], axis=1)


def _entering(state: GraphState) -> np.ndarray:
    """``(C,)``: the verb each creature is entering, or the one it plays alone."""
    return np.where(state.active >= 0, state.into, state.verb)


def _eased(since: np.ndarray, halflife: np.ndarray) -> np.ndarray:
    """The share ``(n,)`` of the examples' lifts the planter keeps a free foot over under a decaying offset: as much
    as the offset has decayed (its spring's weight gone), so the foot is kept over them only as the pose shown has
    become the verb's (``Frame.eased``). Kept over the walk's whole lift at once, the first foot of a start cut short
    by a command (the walk played at once under the offset of the pose shown, still mostly the stand's) rose 4.6 cm
    in a frame, the knee at 750 deg/s. The planter keeps a foot that was higher no lower than a floor rising from
    where it was (``planter.RISE``)."""
    return 1.0 - _spring(1.0, 0.0, since, halflife)


def _standing(state: GraphState) -> np.ndarray:
    """Which creatures stand or are coming to stand ``(C,)``: the verb playing alone, or the one being entered, is a
    one-shot (a stand, a gesture; a stop too)."""
    return ~state.graph.cyclic[_entering(state)]


def _velocity(old: np.ndarray, new: np.ndarray, dt: float) -> np.ndarray:
    """The root velocities ``(C, 3)`` (sideways, forward, turn) that take roots ``old`` to ``new`` in ``dt`` (compiled)."""
    out = np.empty(old.shape)
    root_velocities(np.ascontiguousarray(old), np.ascontiguousarray(new), float(dt), out)
    return out


def _at_blend_speed(state: GraphState, vel: np.ndarray, speed: np.ndarray) -> None:
    """In a cosine blend the body goes at the speed of the blend of the verbs' own velocities (``speed (C,)``,
    :func:`_speeds`; see :func:`_keep_feet`): the velocity ``vel (C, 3)`` it carries into the next step is scaled (in place) to it, so
    the verb left alone when the blend ends goes on from the speed the blend had. The blended velocity itself (each
    verb at its clock's rate in the blend) lagged it: a walk → run ended at 3.0 m/s and its first frame alone went
    2.3, then 3.3 (29 m/s², the run's own 8)."""
    rows = np.flatnonzero(_cosine(state))
    if len(rows) == 0:
        return
    m = np.hypot(vel[rows, 0], vel[rows, 1])
    k = np.where(m > 1e-12, speed[rows] / np.where(m > 1e-12, m, 1.0), 1.0)
    vel[rows, 0] *= k
    vel[rows, 1] *= k


def _cosine(state: GraphState) -> np.ndarray:
    """Which creatures ``(C,)`` are in a cosine blend of two verbs (not inertial, not a verb's loop into itself)."""
    return (state.active >= 0) & ~state.inertial & state.graph.between_verbs[state.active]


def _speeds(state: GraphState, base: _Base, velocity: np.ndarray) -> np.ndarray:
    """The speed ``(C,)`` (m/s) the body of a creature carried by its feet goes at: in a cosine blend, the speed of
    the blend of the two verbs' own horizontal velocities, ``|α v_A + (1 − α) v_B|`` (each at its own clock, as it
    goes alone);
    otherwise (a decaying offset) at least the root's own, ``velocity (C, 3)`` with its inertialized offset."""
    n = state.creatures
    out = np.hypot(velocity[:, 0], velocity[:, 1])
    rows = np.flatnonzero(_cosine(state))
    if len(rows) == 0:
        return out
    v_a, v_b = np.zeros((n, 2)), np.zeros((n, 2))
    for sel, d in base.a.values():
        v_a[sel] = d[:, :2]
    for sel, d in base.b.values():
        v_b[sel] = d[:, :2]
    # The speed of the blend of the two velocities, each at its own clock: the blend of their speeds where they go
    # the same way (a run into a walk), less where they do not. The blend of the speeds kept a body whose verbs went
    # opposite ways (a stand's end swaying back, a reach's start forward) at 2 cm/s while its way turned round in
    # three frames (0.8 m/s², the reach's own 0.15).
    a = base.alpha[rows, None]
    out[rows] = np.hypot(*(a * v_a[rows] + (1.0 - a) * v_b[rows]).T)
    return out


def carry_limits(state: GraphState, rows: np.ndarray) -> np.ndarray:
    """How fast the body of each creature of ``rows`` may change its velocity ``(n,)``, m/s², where it is carried
    (by its held feet in a blend of two verbs or under a decaying offset, or catching up with its verb after one:
    :func:`_keep_feet`): no faster than its verbs' own bodies do at its adverbs, the larger of the verb playing's
    and the one being entered's. A verb's own is how fast the root velocities it plays at the creature's adverbs
    (its examples' ``Verb.root_velocity_samples`` blended with the creature's weights) change over a frame's step of
    its clock, turned with its heading, at its fastest: at least ``SETTLING``, 0.1 m/s² (a stand in place has none
    of its own), at most its examples' fastest (``Verb.root_accelerations``); a bow's 0.6-0.8 m/s², a walk's 2-12.
    Carried at a walk's pace (4 m/s², the limit before), an interruption jumped a standing body at 2-7x its verbs'
    own; at the examples' fastest blended (the limit until session 43), a reach's start cut short turned the body at
    0.32 m/s², the reach's own at its adverbs 0.15. It depends on the adverbs alone, so each verb's is kept once
    worked out (``Verb.carry_limit``, ``clocks._carry``) until they move."""
    out = np.zeros(len(rows))
    for slot, verbs in ((0, state.verb[rows]), (1, state.into[rows])):
        for v in np.unique(verbs[verbs >= 0]):
            mine = verbs == v
            out[mine] = np.maximum(out[mine], _carry(state, int(v), slot, rows[mine]))
    return out


def _body_off_root(state: GraphState, rows: np.ndarray, new_root: np.ndarray, dt: float) -> None:
    """Takes the roots' travel out of the body root's offset velocity ``offset_trans_vel`` of ``rows`` (across the
    floor): the shown root's (its velocity ``shown[2]`` over the step to ``state.root``) less the verbs' (``state.root``
    to ``new_root``), in the frame of the joint above the body root. What is left is how fast the body moved off its
    root as shown, less as the verbs move it."""
    body = state.graph.verbs[0].encoding.body_root
    shown = state.shown[2][rows]
    h0 = state.root[rows, 2]
    was = advance_root(np.c_[np.zeros((len(rows), 2)), h0 - shown[:, 2] * dt], shown, dt)[:, :2] / dt
    now = (new_root[rows, :2] - state.root[rows, :2]) / dt
    d = was - now
    travel = quat.rotate(state.graph.inverse_above_body, np.c_[d[:, 0], np.zeros(len(rows)), d[:, 1]])
    state.offset_trans_vel[rows, body, 0] -= travel[:, 0]
    state.offset_trans_vel[rows, body, 2] -= travel[:, 2]


def _keep_feet(
    state: GraphState, rot: np.ndarray, trans: np.ndarray, root: np.ndarray, held: np.ndarray, roll: np.ndarray,
    offset: np.ndarray, speed: np.ndarray, dt: float,
) -> np.ndarray:  # fmt: skip
    """Roots ``(C, 3)`` of creatures in a cosine blend, or with a decaying ``offset (C,)``, moved so the feet their
    verbs hold stay where they were shown; and of creatures a carry left behind their verb's velocity
    (``GraphState.lagging``), caught up with it no faster than :func:`carry_limits` allows.

    Blending two verbs whose stance feet sit at different places under the body slides a held foot by
    ``α'(A − B)``, however well each verb alone keeps it still; the body is carried instead, by the mean slip of
    the held feet, each weighted by how flat it still is (``1 − roll``), so the weight fades as a foot rolls off.
    ``trans`` (the body root's) is moved with it, in place. A verb's loop into itself blends two instances of one
    verb, which keep their feet alike: its root is the verb's own, so it turns and travels as the verb does. A
    decaying offset (an inertial blend, an interruption) moves the legs as a blend does, and the body is carried
    the same way. The carried body goes along the root's advance at ``speed (C,)`` m/s, the speed of the step's start
    as the root's own advance takes it (:func:`_speeds` a frame ago), in a cosine blend (the blend of the verbs' own),
    and at no less than it under a decaying offset (the root's own), its velocity
    changing no faster than :func:`carry_limits` allows there. Carried
    by the whole slip, a run braked nearly to a standstill on its way into a walk and lurched on, a start threw
    the body past the walk's speed, and a run for a second after an interruption dipped to 1.9 m/s and lurched on
    at 2.6 (root acceleration 18-22 m/s², the run's own 6). The planter's IK takes up the
    rest, and a held foot the body leaves too far behind is re-placed (:class:`~adverbs.graph.planted.GraphFeet`).
    """
    if state.shown is None or state.held_before is None:
        return root
    cosine = _cosine(state)
    blending = offset | cosine
    lagging = state.lagging & ~blending
    if not (blending.any() or lagging.any()):
        return root
    rows = np.flatnonzero(blending | lagging)
    cosine, alone = cosine[rows], lagging[rows]
    w = np.ascontiguousarray((held & state.held_before)[rows] * (1.0 - roll[rows]) * ~alone[:, None])
    graph = state.graph
    root = root.copy()
    # Under a decaying offset alone, the slip carries the body as much as the offset is left (the spring's weight): the
    # carry ends with the offset, not at once when it is over (a bow whose valence eased under it drifted 0.1 m/s,
    # then stopped in one frame: 4 m/s², its own 0.4).
    fade = np.where(cosine | alone, 1.0, _spring(1.0, 0.0, state.offset_since[rows], state.offset_halflife[rows]))
    # ... and its velocity changes from the one shown no faster than its verbs' own allow (carry_limits): a cosine
    # blend had held the body to its speed while the slip ran ahead, and a command that cut it short let the whole
    # slip carry it at once (a start cut short two frames in went from 0.07 to 0.37 m/s in a frame, 13 m/s²).
    # So does a cosine blend into a one-shot (a stop, a gesture): a stop held to the blend's speed alone braked at
    # 7-11 m/s² where the walk's own is 4-6, and a gesture entered from a stand still carrying the stop's last speed
    # dropped it in a frame (its own 0.15 m/s²). So does every other blend of two verbs (a start, one cycle into
    # another), and a body one left behind the verb's velocity (``lagging``) catches up alone at that rate: a CMU
    # walk → run of 0.17 s took the body from 1.3 to 3.0 m/s at 16.5 m/s² (the run's own 8), and held back within
    # the blend alone it took up the rest in one frame once the blend ended (21 m/s²).
    change = carry_limits(state, rows)
    held_back = np.zeros(len(rows), dtype=bool)
    keep_feet(
        graph.skeleton.parents, graph.feet_array, graph.feet_path, rows, w, rot, trans, state.shown[0], state.shown[1],
        np.ascontiguousarray(state.shown[2]), graph.verbs[0].encoding.body_root, graph.inverse_above_body, root,
        state.root, np.where(alone, 0.0, speed[rows]), np.where(cosine, speed[rows], np.inf), change, fade, dt, held_back,
    )  # fmt: skip
    state.lagging[:] = False
    state.lagging[rows] = held_back
    return root


def hold_phases(state: GraphState) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """For every creature and every foot of the graph ``(C, L)``: whether it is held, how far it has rolled off, how
    much of the least swing lift a free foot keeps under it (:func:`adverbs.feet.planter.swing_lifts`), and how high
    the examples lift it (:func:`adverbs.feet.planter.example_lifts`; in a cosine blend, A's and B's blended as the
    pose is, none where either verb has none).

    A verb instance holds a foot as its own hold says at its generic time (the examples' contact times at its adverbs);
    a verb without a hold on that foot never holds it. In a cosine blend a foot is held where A holds it and B does too,
    or A still has the weight (``α ≥ 0.5``): a start's first foot stays down until the walk has the weight, then lifts,
    instead of being drawn backwards along the floor; a stop's swinging foot stays free until the walk itself lands it.
    A foot held so (where A holds it) has the verbs' rolls blended as the pose is, ``α r_A + (1 − α) r_B`` (a foot B
    swings counts as rolled off, 1). Taken as the further of the two whatever their weights, a start whose walk had
    already rolled the trailing foot 0.88 rolled it so in one frame, back to flat when the walk lifted it while the
    stand still had the weight, then to 1 when the walk took it (a Bandai foot held 35° from the stand's turned 30° a
    frame three times); and ``max(α r_A, (1 − α) r_B)`` halved the roll of a foot both roll alike (a verb's loop into
    itself) halfway through. Any other foot (let go, or taken from A's swing) has the roll of the verb with the weight.
    A free foot keeps the swing lift of the verb that swings it (both: the lesser, as the verb that lands it sooner puts
    it down; a foot both hold, the greater, as the one rolling it off lifts it), so a blend with a verb standing on that
    foot does not draw the swing down to the floor: a stop's swinging foot swings as the walk's does and lands as it
    lands. A foot B takes from A's swing as A begins to land it (``LANDS``) has the least lift A kept under it as its
    examples' lift, so the planter lands it where it was shown and settles it onto the floor rather than dropping it
    there in a frame.
    """
    graph = state.graph
    c = state.creatures
    c_all = np.arange(c)
    moving = c_all[state.active >= 0]
    inertial = (state.active >= 0) & state.inertial

    def phases(verbs: np.ndarray, g: np.ndarray, slot: int, rows: np.ndarray) -> tuple[np.ndarray, ...]:
        h = np.zeros((c, len(graph.feet)), dtype=bool)
        r = np.zeros((c, len(graph.feet)))
        s = np.zeros((c, len(graph.feet)))
        e = np.full((c, len(graph.feet)), -np.inf)
        for v, which in _by_verb(verbs, rows):
            verb = graph.verbs[v]
            if verb.holds:
                opens, cols = graph.hold_layout[v]
                hold_rows(g, rows[which], opens, _hold_times(state, v, slot), cols, verb.cyclic, h, r, s)
                mine = rows[which]
                e[mine[:, None], cols] = example_lifts(verb, _sampling(state, v, slot).weights[mine], g[mine])
        return h, r, s, e

    ha, ra, sa, ea = phases(state.verb, state.g, 0, c_all[~inertial])
    if len(moving):
        hb, rb, sb, eb = phases(state.into, state.g_into, 1, moving)
    else:
        return ha, ra, sa, ea
    alone = state.active < 0
    alpha = blend_weight(state.beta)[:, None]  # A's weight in a cosine blend
    first = alpha >= 0.5
    taken = hb & ~ha & (sa < LANDS)  # B takes a foot from A's swing as A begins to land it
    major = (ha & (hb | first)) | taken
    both = ha & hb
    held = np.where(alone[:, None], ha, np.where(inertial[:, None], hb, major))
    rolls = alpha * ra + (1.0 - alpha) * rb  # a foot A holds: the verbs' rolls blended as the pose is
    roll = np.where(alone[:, None], ra, np.where(inertial[:, None], rb, np.where(ha & (hb | first), rolls, np.where(first, ra, rb))))
    # The lift of the verb swinging it; of the one rolling it off, where both hold it (the planter lets such a foot go
    # as the verb lifts its ball): a stop begun as the walk rolled a foot off took the stand's none, and the foot
    # dropped to the floor for a frame while the walk carried it on.
    lift = np.where(ha & ~hb, sb, np.where(hb & ~ha, sa, np.where(both, np.maximum(sa, sb), np.minimum(sa, sb))))
    swing = np.where(alone[:, None], sa, np.where(inertial[:, None], sb, lift))
    mixed = np.where(np.isfinite(ea) & np.isfinite(eb), alpha * np.where(np.isfinite(ea), ea, 0.0)
                     + (1.0 - alpha) * np.where(np.isfinite(eb), eb, 0.0), -np.inf)  # fmt: skip
    # A foot B takes from A's swing is held from where A's swing held it: no lower than the least lift A kept under
    # it (the planter lands a foot where it shows it and settles it onto the floor). Dropped to the verbs' own height
    # at once, a stop's swinging toe fell 29 mm in a frame, the knee at 495 deg/s.
    mixed = np.where(taken, np.maximum(mixed, SWING_LIFT * sa), mixed)
    lifts = np.where(alone[:, None], ea, np.where(inertial[:, None], eb, mixed))
    return held, roll, swing, lifts
