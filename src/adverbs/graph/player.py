"""Creatures moving through a verb graph, one frame at a time (§5): transitions, root bookkeeping, the queue.

:func:`step` advances C creatures by ``dt`` seconds; their progress lives in a :class:`GraphState` the
caller owns (the graph is shared and never changes). Each creature plays one verb instance — a verb
and a generic time ``g`` in it — or is in a transition from one instance (A) to another (B):

* **The queue.** Each creature holds the transitions still to take. A command (:func:`command`) puts
  there the path with the fewest transitions from the verb playing (or, during a transition, the one
  being entered) to the verb asked for. It never runs dry: when it empties, a transition away from the
  verb playing is drawn by likelihood from the creature's own seeded generator.
* **When a transition starts.** When the verb reaches the start of the next transition's region in it
  (``t_s^A``). A cyclic verb whose next region has already gone by in this cycle first takes its loop
  into itself; a one-shot verb already past it starts the transition at once, from where it is.
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
  inertially, when B is a one-shot verb whose way on is already open.
* **Feet.** A foot both verbs hold stays held; blending two stances would slide it, so the body is
  carried by the held feet's slip instead (:func:`_keep_feet`). :class:`GraphFeet` re-places a foot a
  verb playing alone has somewhere else (``REPLANT``).
* **Cycles.** A cyclic verb instance plays one cycle; its loop into itself is a transition like any
  other. Where a target region ends at the end of a cyclic verb's cycle, B plays that region as the
  end of the *previous* cycle (the seam ``d(1) − d(0)`` taken off), so it goes on into its next cycle
  without a jump.
* **The root** is integrated from the blended velocities, so every verb instance starts where the
  creature is, facing where it faces: a walk looping into itself keeps walking on, turns accumulate.

Each frame also gives, for every constrained foot, whether it is held (held in both verbs of a blend;
released by either, released) and how far it has rolled off, for a planter.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import AdverbsError
from ..kinematics import quat
from ..verb._sampling_kernel import GENERIC, VELOCITIES
from ..kinematics.floor import Floor
from ..motion._pose_kernel import blend_poses, root_velocities
from ..motion.encoding import advance_root
from ..verb.planting import BALL, FREE, FootPlanter, _spring, effector_joints
from ..verb.sampling import SamplingState, run_kernel
from ._blend_kernel import decay_offsets, keep_feet
from ._time_kernel import clock_rows, generic_rows, hold_rows, later_rows
from .structure import CommandRefused, Graph

INERTIAL_HALFLIFE = 0.2  # of a transition's duration: the half-life of an inertial offset's decay
INTERRUPT_HALFLIFE = 0.2  # seconds: the shortest half-life of the offset an interruption leaves
MIN_DURATION = 0.1  # seconds: no transition is shorter
_LATE = 1e-9  # generic time: a region start this close behind is not yet gone by


def blend_weight(beta: np.ndarray) -> np.ndarray:
    """The paper's blend weight of the verb being left, ``α = 0.5 cos(βπ) + 0.5``, for ``β`` in ``[0, 1]``."""
    return 0.5 * np.cos(np.clip(beta, 0.0, 1.0) * np.pi) + 0.5


def clock_of(g: np.ndarray, keytimes: np.ndarray, generic: np.ndarray) -> np.ndarray:
    """Clock time of generic times ``g (n,)`` or ``(n, k)`` under each row's ``keytimes (n, N)``; ``g < 0`` is the
    previous cycle.

    :func:`~adverbs.interp.timewarp.clock_time` on the cycle ``g`` falls in, plus the whole cycles before it;
    compiled (:mod:`._time_kernel`).
    """
    return _rows(clock_rows, g, keytimes, generic)


def generic_of(clock: np.ndarray, keytimes: np.ndarray, generic: np.ndarray) -> np.ndarray:
    """Generic time of clock times ``clock (n,)`` or ``(n, k)``: the inverse of :func:`clock_of`."""
    return _rows(generic_rows, clock, keytimes, generic)


def _rows(kernel, x: np.ndarray, keytimes: np.ndarray, generic: np.ndarray, *extra) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    grid = np.ascontiguousarray(x.reshape(len(x), -1))
    out = np.empty(grid.shape)
    kernel(grid, *extra, np.ascontiguousarray(keytimes, dtype=float), np.ascontiguousarray(generic, dtype=float), out)
    return out if x.ndim == 2 else out.reshape(x.shape)


def duration(
    source_region: tuple[float, float], target_region: tuple[float, float], keys_a: np.ndarray, keys_b: np.ndarray,
    generic_a: np.ndarray, generic_b: np.ndarray,
) -> np.ndarray:  # fmt: skip
    """The paper's transition duration ``(n,)``: the mean of the two regions' lengths in clock time under keytimes ``(n, N)``."""
    a = np.asarray(source_region, dtype=float).T
    b = np.asarray(target_region, dtype=float).T
    length_a = clock_of(np.broadcast_to(a[1], len(keys_a)), keys_a, generic_a) - clock_of(np.broadcast_to(a[0], len(keys_a)), keys_a, generic_a)
    length_b = clock_of(np.broadcast_to(b[1], len(keys_b)), keys_b, generic_b) - clock_of(np.broadcast_to(b[0], len(keys_b)), keys_b, generic_b)
    return 0.5 * (length_a + length_b)


@dataclass(eq=False)
class GraphState:
    """Where C creatures are in a graph; owned by the caller. Make one with :func:`new_state`.

    Per creature: ``points (C, A)`` the graph's adverbs; ``verb``, ``g`` the verb instance playing (A);
    ``into``, ``g_into`` the one being entered (B, −1 when none); ``active`` the transition under way
    (−1: none), its ``beta``, ``length`` (seconds) and ``regions (C, 4)`` (A's and B's, generic time, as it
    started); ``root (C, 3)`` = (x, z, heading); ``queue`` the transitions to come; ``goal`` the verb last
    asked for until it plays (−1: none) and when it was asked; the decaying offsets of inertial blends
    and interruptions; the last two frames shown (for the velocities an interruption carries on).
    """

    graph: Graph
    points: np.ndarray
    verb: np.ndarray
    g: np.ndarray
    into: np.ndarray
    g_into: np.ndarray
    active: np.ndarray
    beta: np.ndarray
    length: np.ndarray
    regions: np.ndarray
    root: np.ndarray
    time: np.ndarray
    queue: list[list[int]]
    rngs: list[np.random.Generator]
    goal: np.ndarray
    asked: np.ndarray
    rebase: np.ndarray
    offset_rot: np.ndarray
    offset_rot_vel: np.ndarray
    offset_trans: np.ndarray
    offset_trans_vel: np.ndarray
    offset_root: np.ndarray
    offset_since: np.ndarray
    offset_halflife: np.ndarray
    shown: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    shown_before: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    inertial: np.ndarray | None = None
    alone: np.ndarray | None = None
    stay: np.ndarray | None = None
    held_before: np.ndarray | None = None
    moving: np.ndarray | None = None
    fresh: set | None = None
    regions_seen: dict | None = None
    latencies: list[tuple[int, str, float]] = field(default_factory=list)
    caches: dict = field(default_factory=dict)
    head: np.ndarray | None = None  # (C,) each queue's first transition (−1: empty), kept for the compiled frame

    @property
    def creatures(self) -> int:
        return len(self.verb)

    def playing(self, c: int) -> str:
        """What creature ``c`` is doing, in words."""
        names = self.graph.verb_names
        if self.active[c] >= 0:
            return f"{names[self.verb[c]]} → {names[self.into[c]]} ({self.beta[c]:.0%})"
        return f"{names[self.verb[c]]} at {self.g[c]:.2f}"


def new_state(
    graph: Graph, creatures: int = 1, seed: int = 0, start: str | int | Sequence[str | int] | None = None,
    points: np.ndarray | None = None, root: np.ndarray | None = None, stay: bool | np.ndarray = False,
) -> GraphState:  # fmt: skip
    """C creatures at the start of ``start`` (default the graph's; or one verb per creature), adverbs ``points (C, A)``
    (default the graph's defaults), roots ``(C, 3)``; each draws its default transitions from its own generator
    (``seed`` spawns them), or with ``stay (C,)`` keeps playing its verb (see :func:`command`)."""
    if isinstance(creatures, bool) or not isinstance(creatures, int | np.integer) or creatures < 1:
        raise AdverbsError(f"creatures must be a whole number ≥ 1, got {creatures!r}")
    c = int(creatures)
    if start is None or isinstance(start, str | int | np.integer):
        v = np.full(c, graph.start if start is None else graph.verb_index(start))
    elif len(start) != c:
        raise AdverbsError(f"start names {len(start)} verbs for {c} creatures")
    else:
        v = np.array([graph.start if s is None else graph.verb_index(s) for s in start], dtype=np.int64)
    a = len(graph.adverb_names)
    p = np.tile(graph.defaults, (c, 1)) if points is None else np.array(np.broadcast_to(np.asarray(points, dtype=float), (c, a)))
    if not np.all(np.isfinite(p)):
        bad = graph.adverb_names[int(np.flatnonzero(~np.isfinite(p).all(axis=0))[0])]
        raise AdverbsError(f"adverb {bad!r} must be a finite number (got NaN or infinity)")
    r = np.zeros((c, 3)) if root is None else np.array(np.broadcast_to(np.asarray(root, dtype=float), (c, 3)))
    j = graph.skeleton.num_joints
    state = GraphState(
        graph, p, v, np.zeros(c), np.full(c, -1), np.zeros(c), np.full(c, -1), np.zeros(c), np.zeros(c),
        np.zeros((c, 4)), r, np.zeros(c), [[] for _ in range(c)],
        [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(c)], np.full(c, -1), np.zeros(c),
        np.zeros(c, dtype=bool), np.zeros((c, j, 3)), np.zeros((c, j, 3)), np.zeros((c, j, 3)), np.zeros((c, j, 3)),
        np.zeros((c, 3)), np.full(c, 1e9), np.full(c, INTERRUPT_HALFLIFE),
    )  # fmt: skip
    state.inertial = np.zeros(c, dtype=bool)
    state.stay = np.array(np.broadcast_to(np.asarray(stay, dtype=bool), (c,)))
    state.head = np.full(c, -1, dtype=np.int64)
    for k in range(c):
        _settle_queue(state, k)
    return state


# ----- the queue ----------------------------------------------------------------------------------


def _settle_queue(state: GraphState, c: int, g: float | None = None) -> None:
    """Make creature ``c``'s queue playable from where it is (its generic time ``g``, default now): never empty, and
    a cyclic verb whose next region has gone by in this cycle loops into itself first."""
    graph = state.graph
    q = state.queue[c]
    v = int(state.verb[c])
    loop = graph.loop(v)
    if not q:
        q.append(loop if state.stay[c] and loop is not None else graph.draw(v, state.rngs[c]))
    first = graph.transitions[q[0]]
    g = state.g[c] if g is None else g
    if graph.verbs[v].cyclic and first.source_region[0] < g - _LATE and loop is not None and q[0] != loop:
        q.insert(0, loop)
    sync_head(state, c)


def sync_head(state: GraphState, c: int) -> None:
    """Note creature ``c``'s first queued transition in :attr:`GraphState.head` (−1 when the queue is empty)."""
    if state.head is not None:
        state.head[c] = state.queue[c][0] if state.queue[c] else -1


def command(state: GraphState, creature: int, verb: str | int, stay: bool = False) -> list[int]:
    """Ask creature ``creature`` to perform ``verb``: queue the path with the fewest transitions to it.

    ``stay``: once there, keep playing ``verb`` (through its loop; a verb without one goes on by a drawn transition
    to one that has, and stays there) until the next command; otherwise the queue draws the next transition by
    likelihood whenever it empties. Returns the transitions queued. During an interruptible transition the creature carries on from the
    pose it shows (see the module); otherwise the path starts from the verb being entered once it plays.
    An unknown or unreachable verb raises :class:`CommandRefused` and changes nothing.
    """
    c = int(creature)
    if not 0 <= c < state.creatures:
        raise CommandRefused(f"no creature {c}: there are {state.creatures}")
    try:
        return _command(state, c, verb, stay)
    finally:
        sync_head(state, c)


def _command(state: GraphState, c: int, verb: str | int, stay: bool) -> list[int]:
    graph = state.graph
    target = graph.verb_index(verb)
    now = int(state.into[c]) if state.active[c] >= 0 else int(state.verb[c])
    path = graph.path(now, target)  # raises before anything changes
    state.stay[c] = bool(stay)
    state.goal[c] = target
    state.asked[c] = state.time[c]
    if state.active[c] >= 0 and target != state.into[c] and graph.transitions[state.active[c]].interruptible:
        if target == state.verb[c] and graph.verbs[target].cyclic and not state.inertial[c]:
            _reverse(state, c)  # back to the cycle it was leaving, by the same blend
            state.queue[c] = []
            return []
        _interrupt(state, c)
        state.queue[c] = list(path)
        first = graph.transitions[path[0]]
        if not graph.verbs[first.source].cyclic and state.g[c] >= first.source_region[0]:
            # The way on from the verb being entered is open already: take it at once, from the pose shown.
            _start(state, c, 0.0, inertial=True)
            return list(path)
    state.queue[c] = list(path)
    if state.active[c] < 0:
        _settle_queue(state, c)
        if target == state.verb[c]:
            _arrived(state, c)
    return list(state.queue[c])


def _reverse(state: GraphState, c: int) -> None:
    """Turn creature ``c``'s blend back towards the verb it was leaving: both verbs play on from where they are,
    at the rates they had, and the weight of the one being left climbs back to 1 by the same cosine law."""
    sa, ea, sb, eb = state.regions[c]
    back = 1.0 - state.beta[c]
    a = state.g_into[c] - back * (eb - sb)
    b = state.g[c] - back * (ea - sa)
    state.regions[c] = (a, a + (eb - sb), b, b + (ea - sa))
    state.verb[c], state.into[c] = state.into[c], state.verb[c]
    state.g[c], state.g_into[c] = state.g_into[c], state.g[c]
    state.beta[c] = back


def _interrupt(state: GraphState, c: int) -> None:
    """Drop the verb being left: the one being entered plays on alone from the pose now shown."""
    state.verb[c], state.g[c] = state.into[c], state.g_into[c]
    state.active[c], state.into[c] = -1, -1
    state.rebase[c] = True
    # The rest of the blend is left to the offset's decay, over about the time the blend had still to run.
    state.offset_halflife[c] = max(INERTIAL_HALFLIFE * state.length[c], INTERRUPT_HALFLIFE)
    if state.g[c] < 0.0:  # B was playing the end of its previous cycle: it is that cycle's end now
        state.g[c] += 1.0


def _arrived(state: GraphState, c: int) -> None:
    if state.goal[c] >= 0 and state.verb[c] == state.goal[c] and state.active[c] < 0:
        state.latencies.append((c, state.graph.verb_names[state.goal[c]], float(state.time[c] - state.asked[c])))
        state.goal[c] = -1


# ----- one frame ------------------------------------------------------------------------------------


@dataclass
class Frame:
    """One frame of C creatures: local ``rotations (C, J, 4)``, ``translations (C, J, 3)``, the ``root (C, 3)``,
    the root's velocities ``(C, 3)`` (sideways, forward m/s, turn rad/s), and per foot of the graph's feet
    ``held (C, L)``, ``roll (C, L)`` and ``swing (C, L)`` (see :func:`hold_phases`)."""

    rotations: np.ndarray
    translations: np.ndarray
    root: np.ndarray
    velocity: np.ndarray
    held: np.ndarray
    roll: np.ndarray
    swing: np.ndarray


def feet(graph: Graph) -> list[int]:
    """The effector joints any verb of the graph holds, in the order the first such verb lists them."""
    return list(graph.feet)


def _sampling(state: GraphState, v: int, slot: int) -> SamplingState:
    """Verb ``v``'s cached weights and keytimes for every creature, in slot 0 (A) or 1 (B), up to date."""
    graph = state.graph
    verb = graph.verbs[v]
    key = (v, slot)
    s = state.caches.get(key)
    if s is None:
        s = state.caches[key] = SamplingState.new(verb, state.creatures)
    if state.fresh is None or key not in state.fresh:  # within a step the adverbs hold still: once is enough
        if s.update(verb, graph.verb_points(v, state.points)) and verb.holds:
            times = verb.hold_times(s.weights)  # when each creature's feet land and lift
            held = state.caches.get((key, "holds"))
            if held is None:
                state.caches[key, "holds"] = times
            else:  # in place: the compiled frame holds on to the array
                held[...] = times
        if state.fresh is not None:
            state.fresh.add(key)
    return s


def _hold_times(state: GraphState, v: int, slot: int) -> np.ndarray:
    """Verb ``v``'s hold times ``(C, L, 3)`` at every creature's adverbs in slot 0 (A) or 1 (B) (see :meth:`Verb.hold_times`)."""
    _sampling(state, v, slot)
    return state.caches[(v, slot), "holds"]


def _by_verb(verbs: np.ndarray, rows: np.ndarray) -> list[tuple[int, np.ndarray | slice]]:
    """The verbs ``verbs[rows]`` plays, each with which of ``rows`` play it (a mask, or every one: ``slice(None)``)."""
    vs = verbs[rows]
    if len(vs) == 0:
        return []
    first = vs[0]
    if len(vs) == 1 or not np.any(vs != first):  # one creature, or a crowd all in one verb: no sorting
        return [(int(first), slice(None))]
    return [(int(v), vs == v) for v in np.unique(vs)]


def _warp(state: GraphState, verbs: np.ndarray, x: np.ndarray, slot: int, rows: np.ndarray, convert) -> np.ndarray:
    """``x (n,)`` or ``(n, k)`` of the creatures ``rows`` in their verbs ``verbs[rows]`` (slot A or B) converted by
    ``convert(x, keytimes, generic)`` (generic times to clock times, or back) under each creature's keytimes."""
    out = np.zeros(np.shape(x))
    for v, sel in _by_verb(verbs, rows):
        keys = _sampling(state, v, slot).keytimes[rows[sel]]
        out[sel] = convert(x[sel], keys, state.graph.verbs[v].generic_keytimes)
    return out


def _clock(state: GraphState, verbs: np.ndarray, g: np.ndarray, slot: int, rows: np.ndarray) -> np.ndarray:
    """Clock times of generic times ``g (n,)`` or ``(n, k)``; see :func:`_warp`."""
    return _warp(state, verbs, g, slot, rows, clock_of)


def _generic(state: GraphState, verbs: np.ndarray, clock: np.ndarray, slot: int, rows: np.ndarray) -> np.ndarray:
    """Generic times ``(n,)`` of clock times ``clock (n,)``: the inverse of :func:`_clock`."""
    return _warp(state, verbs, clock, slot, rows, generic_of)


def _later(state: GraphState, verbs: np.ndarray, g: np.ndarray, seconds: float, slot: int, rows: np.ndarray) -> np.ndarray:
    """Generic times ``(n,)`` ``seconds`` of each creature's clock after ``g (n,)``: ``_generic(_clock(g) + seconds)``."""
    return _warp(state, verbs, g, slot, rows, lambda x, keys, generic: _rows(later_rows, x, keys, generic, seconds))


def _start(state: GraphState, c: int, late: float, inertial: bool = False) -> None:
    """Start creature ``c``'s next transition; ``late``: seconds of this frame left after its region began;
    ``inertial``: blend it inertially whatever the graph says (a command that interrupted a blend)."""
    graph = state.graph
    k = state.queue[c].pop(0)
    sync_head(state, c)
    t = graph.transitions[k]
    a, b = graph.verbs[t.source], graph.verbs[t.target]
    (sa, ea), (sb, eb) = t.source_region, t.target_region
    g = float(state.g[c])
    if g > sa + _LATE:  # the region has begun already (a one-shot verb past it, or a loop begun late)
        if g < ea:
            sb += (g - sa) / (ea - sa) * (eb - sb)
            sa = g
        else:
            sa = ea = g
    if b.cyclic and eb >= 1.0:  # B plays the end of its previous cycle
        sb, eb = sb - 1.0, eb - 1.0
    row = np.array([c])
    keys_a = _sampling(state, t.source, 0).keytimes[row]
    keys_b = _sampling(state, t.target, 1).keytimes[row]
    length = float(duration((sa, ea), (sb, eb), keys_a, keys_b, a.generic_keytimes, b.generic_keytimes)[0])
    state.active[c], state.into[c] = k, t.target
    state.regions[c] = (sa, ea, sb, eb)
    state.length[c] = max(length, MIN_DURATION)
    state.beta[c] = min(late / state.length[c], 1.0)
    state.g_into[c] = sb
    state.inertial[c] = inertial or t.blend == "inertial"
    if state.inertial[c]:  # B at once, the pose shown decaying onto it
        state.rebase[c] = True
        state.offset_halflife[c] = max(INERTIAL_HALFLIFE * state.length[c], INTERRUPT_HALFLIFE if inertial else 0.0)


def _finish(state: GraphState, c: int) -> None:
    """End creature ``c``'s transition: B plays on alone."""
    state.verb[c], state.g[c] = state.into[c], state.g_into[c]
    if state.g[c] < 0.0 and abs(state.g[c]) < 1e-9:
        state.g[c] = 0.0
    if not state.graph.verbs[state.verb[c]].cyclic:
        state.g[c] = min(state.g[c], 1.0)
    elif state.g[c] >= 1.0:  # a blend turned back ran a cycle past its end: on in the next (the seam is the fit's)
        state.g[c] -= np.floor(state.g[c])
    state.active[c], state.into[c] = -1, -1
    _settle_queue(state, c)
    _arrived(state, c)


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


def _place(state: GraphState, rows: np.ndarray) -> None:
    """Put A and B of the creatures ``rows`` in transition where ``β`` says: each clock through its region."""
    if len(rows) == 0:
        return
    ca, cb = _region_clocks(state, rows)
    beta = state.beta[rows]
    state.g[rows] = _generic(state, state.verb, ca[:, 0] + beta * (ca[:, 1] - ca[:, 0]), 0, rows)
    # B runs through its region, or (inertial) by its own clock from the region's start.
    run = np.where(state.inertial[rows], state.length[rows], cb[:, 1] - cb[:, 0])
    state.g_into[rows] = _generic(state, state.into, cb[:, 0] + beta * run, 1, rows)


def _region_clocks(state: GraphState, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Clock times ``(n, 2)`` of the start and end of A's region and of B's in the transitions of ``rows``.

    Within a step the keytimes hold still, so the same creatures in the same transitions and regions give the same
    clocks: they are kept for the step (a step asks for them twice: to place A and B, and for their rates)."""
    regions = state.regions[rows]
    key = None
    if state.regions_seen is not None:
        key = (rows.tobytes(), regions.tobytes(), state.verb[rows].tobytes(), state.into[rows].tobytes())
        if key in state.regions_seen:
            return state.regions_seen[key]
    out = _clock(state, state.verb, regions[:, :2], 0, rows), _clock(state, state.into, regions[:, 2:], 1, rows)
    if key is not None:
        state.regions_seen[key] = out
    return out


def _rates(state: GraphState, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """How fast A's and B's clocks run in the transitions of ``rows`` (seconds of verb per second)."""
    ca, cb = _region_clocks(state, rows)
    length = state.length[rows]
    return (ca[:, 1] - ca[:, 0]) / length, np.where(state.inertial[rows], 1.0, (cb[:, 1] - cb[:, 0]) / length)


def _dofs(state: GraphState, verbs: np.ndarray, g: np.ndarray, slot: int, rows: np.ndarray) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """DOFs of each verb at generic times ``g (C,)`` for the creatures ``rows``: verb → (its rows, DOFs (n, D))."""
    out = {}
    for v, which in _by_verb(verbs, rows):
        sel = rows[which]
        verb = state.graph.verbs[v]
        s = _sampling(state, v, slot)
        lap = np.floor(g[sel])
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


def _decode(state: GraphState, base: _Base, root: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Local rotations and translations of every creature at ``root (C, 3)``: A and B decoded, then blended by
    ``alpha`` on the rotations (slerp) and translations (linearly)."""
    j = state.graph.skeleton.num_joints
    n = state.creatures

    def decoded(slot: dict) -> tuple[np.ndarray, np.ndarray]:
        rot, trans = np.empty((n, j, 4)), np.empty((n, j, 3))
        for v, (sel, d) in slot.items():
            state.graph.verbs[v].encoding.decode_into(d, root[sel], sel, rot, trans)
        return rot, trans

    rot, trans = decoded(base.a)
    if base.b:
        rot_b, trans_b = decoded(base.b)
        r = np.flatnonzero(state.active >= 0)
        blend_poses(rot, trans, rot_b, trans_b, r, np.ascontiguousarray(base.alpha[r]))
    return rot, trans


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
    state.moving = vel
    rot, trans = _decode(state, base, new_root)
    if before is not None:
        rot0, trans0 = _decode(state, before, state.root)
        s_rot, s_trans, _ = state.shown
        state.offset_rot[rows] = _relative(s_rot[rows], rot0[rows])
        state.offset_trans[rows] = s_trans[rows] - trans0[rows]
        state.offset_rot_vel[rows] = 0.0
        state.offset_trans_vel[rows] = 0.0
        if state.shown_before is not None:
            b_rot, b_trans, _ = state.shown_before
            state.offset_rot_vel[rows] = (_relative(s_rot[rows], b_rot[rows]) - _relative(rot[rows], rot0[rows])) / dt
            state.offset_trans_vel[rows] = ((s_trans[rows] - b_trans[rows]) - (trans[rows] - trans0[rows])) / dt
        # The root's own travel is the root's: only heights and the pose carry an offset.
        body = state.graph.verbs[0].encoding.body_root
        state.offset_trans[rows, body, 0] = state.offset_trans[rows, body, 2] = 0.0
        state.offset_trans_vel[rows, body, 0] = state.offset_trans_vel[rows, body, 2] = 0.0
    if len(live):
        decay_offsets(
            live, state.offset_since[live], state.offset_halflife[live], state.offset_rot, state.offset_rot_vel,
            state.offset_trans, state.offset_trans_vel, rot, trans,
        )  # fmt: skip
    held, roll, swing = hold_phases(state)
    blended = np.zeros(state.creatures, dtype=bool)
    blended[live] = True
    state.alone = (state.active < 0) & ~blended
    new_root = _keep_feet(state, rot, trans, new_root, held, roll, blended)
    vel = _velocity(state.root, new_root, dt)
    state.root = new_root
    state.shown_before, state.shown = state.shown, (rot, trans, vel)
    state.held_before = held
    return Frame(rot, trans, new_root.copy(), vel, held, roll, swing)


def first_frame(state: GraphState) -> Frame:
    """The frame the creatures show where they start, before any :func:`step`: time 0 of a recording.

    Nothing moves: each verb is sampled where it stands, the root where it was put; the next :func:`step`
    carries on from this frame as from any other shown.
    """
    if np.any(state.time != 0.0):
        raise AdverbsError("first_frame: the creatures have already moved (it is the frame before any step)")
    base = _sample(state, state.g, state.g_into)
    rot, trans = _decode(state, base, state.root)
    held, roll, swing = hold_phases(state)
    state.alone = state.active < 0
    state.moving = base.velocity.copy()
    state.shown, state.held_before = (rot, trans, base.velocity.copy()), held
    return Frame(rot, trans, state.root.copy(), base.velocity.copy(), held, roll, swing)


def _velocity(old: np.ndarray, new: np.ndarray, dt: float) -> np.ndarray:
    """The root velocities ``(C, 3)`` (sideways, forward, turn) that take roots ``old`` to ``new`` in ``dt`` (compiled)."""
    out = np.empty(old.shape)
    root_velocities(np.ascontiguousarray(old), np.ascontiguousarray(new), float(dt), out)
    return out


def _keep_feet(
    state: GraphState, rot: np.ndarray, trans: np.ndarray, root: np.ndarray, held: np.ndarray, roll: np.ndarray,
    offset: np.ndarray,
) -> np.ndarray:  # fmt: skip
    """Roots ``(C, 3)`` of creatures in a cosine blend, or with a decaying ``offset (C,)``, moved so the feet their
    verbs hold stay where they were shown.

    Blending two verbs whose stance feet sit at different places under the body slides a held foot by
    ``α'(A − B)``, however well each verb alone keeps it still; the body is carried instead, by the mean slip of
    the held feet, each weighted by how flat it still is (``1 − roll``), so the weight fades as a foot rolls off.
    ``trans`` (the body root's) is moved with it, in place. A verb's loop into itself blends two instances of one
    verb, which keep their feet alike: its root is the verb's own, so it turns and travels as the verb does. A
    decaying offset (an inertial blend, an interruption) moves the legs as a blend does, and the body is carried
    the same way.
    """
    if state.shown is None or state.held_before is None:
        return root
    blending = offset | ((state.active >= 0) & ~state.inertial & state.graph.between_verbs[state.active])
    if not blending.any():
        return root
    rows = np.flatnonzero(blending)
    w = np.ascontiguousarray((held & state.held_before)[rows] * (1.0 - roll[rows]))
    graph = state.graph
    root = root.copy()
    keep_feet(
        graph.skeleton.parents, graph.feet_array, rows, w, rot, trans, state.shown[0], state.shown[1],
        graph.verbs[0].encoding.body_root, graph.inverse_above_body, root,
    )  # fmt: skip
    return root


def hold_phases(state: GraphState) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For every creature and every foot of the graph ``(C, L)``: whether it is held, how far it has rolled off, and
    how much of the least swing lift a free foot keeps under it (:func:`adverbs.verb.planting.swing_lifts`).

    A verb instance holds a foot as its own hold says at its generic time (the examples' contact times at its
    adverbs); a verb without a hold on that foot never holds it. In a cosine blend a foot is held only where
    both verbs hold it (released by either, released), has rolled as far as the further of the two, and keeps
    the lesser swing lift (the verb that lands it sooner puts it down).
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
        for v, which in _by_verb(verbs, rows):
            verb = graph.verbs[v]
            if verb.holds:
                opens, cols = graph.hold_layout[v]
                hold_rows(g, rows[which], opens, _hold_times(state, v, slot), cols, verb.cyclic, h, r, s)
        return h, r, s

    ha, ra, sa = phases(state.verb, state.g, 0, c_all[~inertial])
    if len(moving):
        hb, rb, sb = phases(state.into, state.g_into, 1, moving)
    else:
        return ha, ra, sa
    alone = state.active < 0
    held = np.where(alone[:, None], ha, np.where(inertial[:, None], hb, ha & hb))
    roll = np.where(alone[:, None], ra, np.where(inertial[:, None], rb, np.maximum(ra, rb)))
    swing = np.where(alone[:, None], sa, np.where(inertial[:, None], sb, np.minimum(sa, sb)))
    return held, roll, swing


REPLANT = 0.06  # metres: a held foot this far (across the floor) from where the verb playing has it is re-placed
REPLANTED = 0.01  # metres: ... until the released foot is this near the verb's again


@dataclass
class GraphFeet:
    """A graph's foot planter for C creatures (:func:`planter`), and which feet it is moving to a new place.

    A foot held across verbs that stand it in different places (a stand with the feet apart, then a walk)
    ends up held where the verb playing does not have it, and the leg stretches. Such a foot, once a verb
    plays alone and it is ``REPLANT`` away, is let go (the planter's inertialized release: it lifts, then
    glides) and held again once it has come within ``REPLANTED`` of where the verb puts it.
    """

    planter: FootPlanter
    replanting: np.ndarray

    @property
    def mode(self) -> np.ndarray:
        return self.planter.mode

    @property
    def turn(self) -> np.ndarray:
        return self.planter.turn

    @property
    def tips(self) -> np.ndarray:
        return self.planter.tips


def planter(graph: Graph, creatures: int = 1, floor: Floor | None = None) -> GraphFeet:
    """The foot planter for ``creatures`` creatures of ``graph``, fed each frame's :attr:`Frame.held` and
    :attr:`Frame.roll` and :attr:`Frame.swing` by :func:`plant`. Its legs and contact heights are those of the first verb that holds feet;
    every verb that holds any must hold the same ones."""
    holding = [v for v in graph.verbs if v.holds]
    if not holding:
        raise AdverbsError(f"graph {graph.name!r}: no verb holds a foot: nothing to plant")
    tips = effector_joints(holding[0])
    for v in holding[1:]:
        if effector_joints(v) != tips:
            names = graph.skeleton.names
            raise AdverbsError(
                f"graph {graph.name!r}: verb {v.name!r} holds {[names[j] for j in effector_joints(v)]}, verb "
                f"{holding[0].name!r} holds {[names[j] for j in tips]}: a graph's verbs must plant the same feet"
            )
    return GraphFeet(FootPlanter(holding[0], creatures, floor), np.zeros((creatures, len(tips)), dtype=bool))


def plant(feet: GraphFeet, frame: Frame, dt: float, alone: np.ndarray | None = None):
    """The frame's feet planted: rotations ``(C, J, 4)``, translations ``(C, J, 3)`` and the IK result.

    ``alone (C,)``: which creatures play one verb alone this frame (no blend, no decaying offset); only their
    feet are re-placed (see :class:`GraphFeet`). Default: none.
    """
    p = feet.planter
    held = frame.held & ~feet.replanting
    out = p.step(frame.rotations, frame.translations, None, dt, (held, frame.roll, frame.swing))
    if feet.replanting.any():
        settled = np.linalg.norm(p._offset(), axis=-1) < REPLANTED
        feet.replanting &= ~((p.mode == FREE) & settled & (p.since[..., 0] > 0))
    if alone is not None:
        away = p.prev_free - p.target
        gap = np.hypot(away[..., 0], away[..., 2])
        feet.replanting |= alone[:, None] & (p.mode == BALL) & (p.turn == 0.0) & (gap > REPLANT)
    return out
