"""Where C creatures are in a verb graph (§5): :class:`GraphState`, owned by the caller (the graph is shared and
never changes), made by :func:`new_state`; and what keeps each creature's queue of transitions playable.

Each creature plays one verb instance — a verb and a generic time ``g`` in it — or is in a transition from one
instance (A) to another (B). Its queue holds the transitions still to take; it never runs dry: when it empties,
a transition away from the verb playing is drawn by likelihood from the creature's own seeded generator (or,
told to stay, its loop into itself). A cyclic verb whose next region has already gone by in this cycle first
takes its loop.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import AdverbsError
from .structure import Graph


INERTIAL_HALFLIFE = 0.2  # of a transition's duration: the half-life of an inertial offset's decay
INTERRUPT_HALFLIFE = 0.2  # seconds: the shortest half-life of the offset an interruption leaves
# A walk's and a run's feet agree over a quarter of their cycles, so their blends last 0.2-0.3 s; the arms, bent 80°
# more in a run, turned at 2.5-3.9x their verbs' own fastest through them. Past a blend into a cycle (from another
# cycle, or a start from a stand) that is shorter than this, the upper body (Graph.carried: the trunk above the hips,
# the head, the arms) plays the verb entered at once and carries the pose shown's difference from it on, fading over
# this long (player._arms). A stop carries it over its own blend.
ARMS_BLEND = 1.6  # seconds
MIN_DURATION = 0.1  # seconds: no transition is shorter (but a verb's loop into itself, :data:`MIN_LOOP`)
# A verb's loop into itself blends two instances of one verb at one phase, so a short blend pops nothing; stretched to
# MIN_DURATION, a loop begun late near its region's end slowed the verb's clock tenfold (a CMU run's root from 3 to
# 0.3 m/s for 0.1 s, then back). It takes what is left of its region, however short.
MIN_LOOP = 1e-6  # seconds
# A blend between standing verbs (Graph.paced_transitions) turns each joint by α' times the angle between the verbs'
# poses; over the mean of its regions' lengths, a stand into a sad bow turned the head at 2.4x the bow's own fastest
# (the two hold the head 25° apart). It lasts long enough that, by its blending alone, no part turns faster than
# PACE times the part's own fastest in the two verbs at the creature's adverbs (clocks.paced_length).
PACE = 1.0
# Between two verbs that stand on their feet (in_place = "feet"), the hips move from over one verb's stance to over the
# other's as the blend goes, no faster than PLACE_PACE times their own fastest (Verb.body_speed_profile). The Bandai
# stand into the guide moves them 5-11 cm; with the stand and gestures on their feet and paced as the joints are
# (1.0), 23 windows of 30 random scripts (seeds 200-229) accelerated the hips past 1.5x the verbs' own (up to 2.5x,
# the stand into the guide and the reach); at 0.5, 2 (1.5x and 2.0x).
PLACE_PACE = 0.5
MOST_PACED = 2.0  # seconds: ... but no longer than this (a sad stand into a sad reach asked for 2.8)
_LATE = 1e-9  # generic time: a region start this close behind is not yet gone by


@dataclass(eq=False)
class GraphState:
    """Where C creatures are in a graph; owned by the caller. Make one with :func:`new_state`.

    Per creature: ``points (C, A)`` the graph's adverbs; ``verb``, ``g`` the verb instance playing (A);
    ``into``, ``g_into`` the one being entered (B, −1 when none); ``active`` the transition under way
    (−1: none), its ``beta``, ``length`` (seconds) and ``regions (C, 4)`` (A's and B's, generic time, as it
    started); ``root (C, 3)`` = (x, z, heading); ``queue`` the transitions to come; ``goal`` the verb last
    asked for until it plays (−1: none) and when it was asked; the decaying offsets of inertial blends
    and interruptions; the upper body's offset a short blend into a cycle carries on (``arms_rot``,
    ``arms_vel (C, U, 3)`` over ``Graph.carried``: the arms, and with ``arms_upper`` the rest of the upper body too;
    taken ``arms_since`` seconds ago for transition ``arms_of``, to fade over ``arms_length`` seconds; ``arms_take``:
    take it at the next frame); the last two frames shown (for the velocities
    an interruption carries on); ``lagging``: the body's velocity was held back by its carry limit last frame, so it
    goes on catching up with its verb's at that rate (``player._keep_feet``).
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
    arms_rot: np.ndarray | None = None
    arms_vel: np.ndarray | None = None
    arms_since: np.ndarray | None = None
    arms_of: np.ndarray | None = None
    arms_take: np.ndarray | None = None
    arms_length: np.ndarray | None = None
    arms_upper: np.ndarray | None = None
    shown: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    shown_before: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    inertial: np.ndarray | None = None
    alone: np.ndarray | None = None
    standing: np.ndarray | None = None  # (C,) the verb playing alone, or the one entered, is a one-shot: planted.plant
    stay: np.ndarray | None = None
    held_before: np.ndarray | None = None
    lagging: np.ndarray | None = None  # (C,) the body's velocity held back by its carry limit last frame (player._keep_feet)
    moving: np.ndarray | None = None
    fresh: set | None = None
    regions_seen: dict | None = None
    latencies: list[tuple[int, str, float]] = field(default_factory=list)
    caches: dict = field(default_factory=dict)
    head: np.ndarray | None = None  # (C,) each queue's first transition (−1: empty), kept for the compiled frame
    cache_version: int = 0  # counts the times a verb's cached rows changed (clocks._sampling), for the compiled frame
    head_version: int = 0  # counts the times a queue's first transition was noted (sync_head), for the compiled frame
    head_stamp: np.ndarray | None = None  # (C,) head_version when each creature's was last noted (planted.know_levels)

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
    seeds: Sequence[int] | None = None,
) -> GraphState:  # fmt: skip
    """C creatures at the start of ``start`` (default the graph's; or one verb per creature), adverbs ``points (C, A)``
    (default the graph's defaults), roots ``(C, 3)``; each draws its default transitions from its own generator
    (``seed`` spawns them; or ``seeds (C,)``: creature ``k`` draws as the one creature of ``new_state(graph, 1,
    seeds[k])`` does, whatever the others), or with ``stay (C,)`` keeps playing its verb (see :func:`command`)."""
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
        _generators(c, seed, seeds), np.full(c, -1), np.zeros(c),
        np.zeros(c, dtype=bool), np.zeros((c, j, 3)), np.zeros((c, j, 3)), np.zeros((c, j, 3)), np.zeros((c, j, 3)),
        np.zeros((c, 3)), np.full(c, 1e9), np.full(c, INTERRUPT_HALFLIFE),
    )  # fmt: skip
    state.inertial = np.zeros(c, dtype=bool)
    state.lagging = np.zeros(c, dtype=bool)
    state.arms_rot, state.arms_vel = np.zeros((c, len(graph.carried), 3)), np.zeros((c, len(graph.carried), 3))
    state.arms_since, state.arms_of = np.full(c, np.inf), np.full(c, -1, dtype=np.int64)
    state.arms_take, state.arms_length = np.zeros(c, dtype=bool), np.full(c, ARMS_BLEND)
    state.arms_upper = np.zeros(c, dtype=bool)
    state.stay = np.array(np.broadcast_to(np.asarray(stay, dtype=bool), (c,)))
    state.head = np.full(c, -1, dtype=np.int64)
    state.head_stamp = np.zeros(c, dtype=np.int64)
    for k in range(c):
        _settle_queue(state, k)
    return state



def _generators(c: int, seed: int, seeds: Sequence[int] | None) -> list[np.random.Generator]:
    """Each creature's generator: spawned from ``seed``, or the first spawned from each of ``seeds``."""
    if seeds is None:
        return [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(c)]
    if len(seeds) != c:
        raise AdverbsError(f"seeds gives {len(seeds)} seeds for {c} creatures")
    return [np.random.default_rng(np.random.SeedSequence(int(s)).spawn(1)[0]) for s in seeds]


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
    state.head_version += 1
    if state.head_stamp is not None:
        state.head_stamp[c] = state.head_version
