"""The frame as one compiled pass: events decide in Python, every creature's frame runs in one kernel.

Two kinds of work, kept apart (the runtime of §6, laid out as ozz-animation lays out its jobs):

* **Events decide**, in Python, at the times they happen: a command (:func:`adverbs.graph.queue.command`), the
  queue (a transition popped when it starts, one drawn by likelihood when the queue empties), a latency noted,
  an adverb point changed (each verb's cached weights, keytimes and hold times brought up to date for the
  creatures whose point moved). They write into the creatures' arrays: the
  :class:`~adverbs.graph.state.GraphState` and the planter's state, owned by the caller.
* **Frames compute**: :meth:`FramePass.step` runs :func:`adverbs.runtime._frame_kernel.frame` once for every
  creature of a group — clocks → sample (one or two verbs) → blend → decode → advance the root → FK → plant →
  IK → the pose shown — reading the graph's immutable tables (laid out once, :func:`tables`) and those arrays,
  on every core, with no Python per creature. One creature is ``C = 1`` through the same pass.

The pass computes what :func:`adverbs.graph.player.step` then :func:`adverbs.graph.planted.plant` compute (the
readable path, kept as the reference and for what the kernel does not take: DOF encodings other than
log-quaternions, floors given as Python functions): ``tests/test_frame.py`` holds the two together over a long
seeded run of the shipped graphs, and holds one thread to all.

The poses a step returns are the pass's own buffers, written again two frames later: copy what you keep.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import operator
import os
from dataclasses import dataclass
from weakref import WeakKeyDictionary

import numpy as np
import numba

from ..errors import AdverbsError
from ..graph import clocks, planted, player, queue, state as graph_state
from ..graph.planted import GraphFeet, know_levels
from ..graph.state import GraphState, sync_head
from ..graph.structure import Graph
from ..motion.encoding import stance_joints
from ..feet import planter as planting
from ..verb import tables as verb_tables
from ..verb.sampling import SamplingState
from . import _frame_kernel as kernel
from ._borrow_kernel import Held, hold

CHUNK = 64  # creatures: each chunk allocates the kernel's working arrays once a frame, and plants its feet in one call
PER_THREAD = 32  # creatures: fewer than this many per thread run on the calling thread alone


@dataclass(frozen=True, eq=False)
class Tables:
    """A graph's immutable tables as the kernel takes them (see :mod:`._frame_kernel`): ``verbs``, ``transitions``,
    the widest DOF row ``dofs``, and the skeleton's ``parents``, feet, inverse rest rotation above the body root
    and the body root."""

    verbs: tuple
    transitions: tuple
    dofs: int
    skeleton: tuple


_TABLES: WeakKeyDictionary = WeakKeyDictionary()


def supported(graph: Graph) -> str | None:
    """Why the compiled pass cannot play ``graph`` (None if it can)."""
    for v in graph.verbs:
        if v.encoding.kind != "logquat":
            return f"verb {v.name!r} is encoded as {v.encoding.kind!r}; the compiled frame decodes log-quaternions"
    return None


def packed(arrays: list[np.ndarray], dtype=float) -> tuple[np.ndarray, np.ndarray]:
    """Arrays of different shapes as one flat array and the offsets ``(n + 1,)`` of each one's part in it."""
    sizes = [np.size(a) for a in arrays]
    flat = np.concatenate([np.ravel(np.asarray(a, dtype=dtype)) for a in arrays]) if arrays else np.zeros(0, dtype)
    return np.ascontiguousarray(flat, dtype=dtype), np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)


def tables(graph: Graph) -> Tables:
    """``graph``'s tables laid out for the kernel (once per graph; a graph never changes)."""
    found = _TABLES.get(graph)
    if found is not None:
        return found
    why = supported(graph)
    if why:
        raise AdverbsError(f"graph {graph.name!r}: {why}")

    vs = graph.verbs
    enc = [v.encoding for v in vs]
    no_window = np.zeros(3)
    verbs = (
        *packed([v.segments for v in vs]),
        np.array([v.segments.shape for v in vs], dtype=np.int64),
        *packed([v.generic_keytimes for v in vs]),
        np.array([v.cyclic for v in vs], dtype=np.bool_),
        *packed([np.zeros(0) if v.goal is None else v.goal.columns for v in vs], np.int64),
        np.array([no_window if v.goal is None else v.goal.window for v in vs], dtype=float),
        *packed([e.rotated for e in enc], np.int64),
        np.array([e.reference for e in enc], dtype=float),
        *packed([e.translated for e in enc], np.int64),
        np.array([e.base_translations for e in enc], dtype=float),
        np.array([e.body_root for e in enc], dtype=np.int64),
        np.array([e.above_body[0] for e in enc], dtype=np.bool_),
        np.array([e.above_body[1] for e in enc], dtype=float),
        np.array([e.above_body[2] for e in enc], dtype=float),
        *packed([opens for opens, _ in graph.hold_layout]),
        *packed([cols for _, cols in graph.hold_layout], np.int64),
        np.array([bool(v.holds) for v in vs], dtype=np.bool_),
        *packed([v.lift_table if v.holds and v.cyclic else np.zeros(0) for v in vs]),
        np.array([v.lift_table.shape[1:] if v.holds and v.cyclic else (0, 2, 0) for v in vs], dtype=np.int64),
        *packed([v.root_accelerations for v in vs]),
        *packed([v.root_velocity_samples for v in vs]),
        *packed(list(graph.speed_profiles)),
        *packed(list(graph.part_speeds)),
        np.array([m.shape for m in graph.speed_profiles], dtype=np.int64),
    )  # fmt: skip
    ts = graph.transitions
    transitions = (
        np.array([(*t.source_region, *t.target_region) for t in ts], dtype=float),
        np.array([t.target for t in ts], dtype=np.int64),
        np.array([t.blend == "inertial" for t in ts], dtype=np.bool_),
        np.ascontiguousarray(graph.between_verbs, dtype=np.bool_),
        np.ascontiguousarray(graph.carries_arms, dtype=np.int64),
        np.ascontiguousarray(graph.paced_transitions, dtype=np.bool_),
    )
    skeleton = (
        np.asarray(graph.skeleton.parents, dtype=np.int64), np.ascontiguousarray(graph.feet_array, dtype=np.int64),
        np.ascontiguousarray(graph.inverse_above_body, dtype=float), int(vs[0].encoding.body_root),
        np.ascontiguousarray(graph.carried, dtype=np.int64), np.ascontiguousarray(graph.paced_joints, dtype=np.int64),
        graph.feet_path,  # what keep_feet_row's FK runs through
        np.array(stance_joints(graph.skeleton) or [vs[0].encoding.body_root], dtype=np.int64),  # tables.body_place
        len(graph.arms),  # the first of the carried joints: the arms (Graph.carried)
    )  # fmt: skip
    out = Tables(verbs, transitions, max(v.num_dofs for v in vs), skeleton)
    _TABLES[graph] = out
    return out


def _constants() -> np.ndarray:
    """The kernel's constants ``k_`` (see ``_frame_kernel``)."""
    return np.array([
        graph_state._LATE, graph_state.MIN_DURATION, graph_state.INERTIAL_HALFLIFE, planting._LN2, planted.REPLANT,
        planted.REPLANTED, planting.SWING_HALFLIFE, planting.LIFT_HALFLIFE, player.LANDS,
        planted.LEFT_BEHIND, planted.STEP_RISE, planted.STEP_DELAY, planted.STEP_LAND, graph_state.MIN_LOOP,
        planted.STANDING, planted.SHIFTED, planting.SWING_LIFT, graph_state.ARMS_BLEND, graph_state.PACE,
        graph_state.MOST_PACED, planted.STOPPING, verb_tables.SETTLING, verb_tables.FRAME, graph_state.PLACE_PACE,
    ])  # fmt: skip


class FramePass:
    """The compiled frame of one group of creatures on one graph: its state (a
    :class:`~adverbs.graph.state.GraphState`) and, to plant their feet, its :class:`~adverbs.graph.planted.GraphFeet`
    (both the caller's), and the pass's working buffers.

    ``threads``: how many threads the pass may use (default: numba's, every core); results are the same for any.
    """

    def __init__(self, state: GraphState, feet: GraphFeet | None = None, threads: int | None = None):
        graph = state.graph
        self.state, self.graph = state, graph
        self.tables = tables(graph)
        self.use_feet(feet)  # refused before anything is made if the floor is one the kernel cannot take
        if state.head is None:
            state.head = np.full(state.creatures, -1, dtype=np.int64)
        if state.head_stamp is None:
            state.head_stamp = np.zeros(state.creatures, dtype=np.int64)
        for c in range(state.creatures):
            sync_head(state, c)
        self._pool = Threads(threads)
        self._kernel, self._planted_kernel = Entry(kernel.frame), Entry(kernel.frame_planted)
        self._same = Entry(kernel.same)
        self._pairs = 2 * len(graph.verbs)
        self._seen = state.points.copy()  # the adverb points the caches were last brought up to date for
        self._fresh: set[tuple[int, int]] = set()  # the (verb, slot) caches up to date at those points
        self._version = 0  # state.cache_version when they were
        self._caches = self._packed_caches()
        c, j, n_l = state.creatures, graph.skeleton.num_joints, len(graph.feet)
        self._poses = [(np.zeros((c, j, 4)), np.zeros((c, j, 3)), np.zeros((c, 3))) for _ in range(3)]
        self._turns = (0, 1, 2)  # which of the pose buffers is written next, shown, and shown before
        self._planted = [(np.zeros((c, j, 4)), np.zeros((c, j, 3))) for _ in range(2)]
        self._turn = 0  # which planted buffer is written next
        self._box_key: tuple | None = None
        self._boxed = None
        self._feet_key: tuple | None = None
        self._feet_boxed = None
        self.held, self.roll, self.swing = np.zeros((c, n_l), dtype=bool), np.zeros((c, n_l)), np.zeros((c, n_l))
        self.lifts = np.full((c, n_l), -np.inf)
        self.eased = np.ones(c)
        # Which creatures play one verb, and which stand (GraphState.alone, .standing): one array, so the kernel's
        # outputs stay seven (an eighth array in them cost a tenth of a crowd's frame, 10,000 creatures 94 -> 105 ms;
        # why was not found).
        self.kinds = np.zeros((c, 3), dtype=bool)  # alone, standing, stopping (a cycle blending into a one-shot)
        self.alone, self.standing = self.kinds[:, 0], self.kinds[:, 1]
        self.events = np.zeros(c, dtype=np.int64)
        self.g_settle = np.zeros(c)
        self.constants = _constants()

    def use_feet(self, feet: GraphFeet | None) -> None:
        """Plant with ``feet`` from the next step on (a planter started afresh, as ``Simulation.plant`` makes one)."""
        if feet is not None and feet.planter._compiled is None:
            raise AdverbsError("the compiled frame plants on flat floors, slopes and height maps; this floor is a function")
        self.feet = feet
        self._feet_key = self._feet_boxed = None
        if feet is not None:
            c, j, n = self.state.creatures, self.graph.skeleton.num_joints, len(feet.planter._compiled.tips)
            self._inside = np.zeros((c, n), dtype=bool)
            self._ik_out = (np.empty((c, j, 3)), np.empty((c, j, 4)), np.empty((c, n, 3)), np.empty((c, n, 3, 3)))
            self._drop, self._residual = np.empty(c), np.empty((c, n))

    def _packed_caches(self) -> tuple:
        """Every verb's sampling caches in both slots as views of one ``(C, Σ)`` table per kind and slot, with each
        kind's offsets (see ``_frame_kernel``): the :class:`~adverbs.verb.sampling.SamplingState` of each verb and
        slot is made (or its rows copied) on those views and brought up to date, so the reference path's caches and
        the pass's are the same numbers."""
        state, graph = self.state, self.graph
        c = state.creatures
        widths = [
            [v.weight_columns for v in graph.verbs],
            [v.keytimes_table.shape[1] for v in graph.verbs],
            [v.num_dofs for v in graph.verbs],
            [0 if v.goal is None else len(v.goal.columns) for v in graph.verbs],
            [3 * len(v.holds) for v in graph.verbs],
            [1 for _ in graph.verbs],  # the carry limit (Verb.carry_limit)
        ]
        offsets = tuple(np.concatenate([[0], np.cumsum(w)]).astype(np.int64) for w in widths)
        tables = tuple(np.zeros((c, int(off[-1]))) for off in offsets for _ in (0, 1))
        for v, verb in enumerate(graph.verbs):
            for slot in (0, 1):
                views = [tables[2 * kind + slot][:, off[v] : off[v + 1]] for kind, off in enumerate(offsets)]
                held = views[4].reshape(c, len(verb.holds), 3)  # a view still: its rows' columns are contiguous
                carry = views[5][:, 0]
                carry[...] = np.nan  # not worked out yet (clocks._carry)
                old = state.caches.get((v, slot))
                new = SamplingState.new(verb, c) if old is None else dataclasses.replace(old)
                for name, view in zip(("weights", "keytimes", "seam", "goal"), views):
                    view[...] = getattr(new, name)
                    setattr(new, name, view)
                state.caches[v, slot] = new
                for name, view in (("holds", held), ("carry", carry)):
                    if old is not None and state.caches.get(((v, slot), name)) is not None:
                        view[...] = state.caches[(v, slot), name]
                    state.caches[(v, slot), name] = view
        self._bring_up_to_date()
        self._version = state.cache_version
        return tables, offsets

    def _bring_up_to_date(self) -> None:
        """Every verb's caches in both slots brought up to date, but for those a verb refuses at the creatures' points
        where no creature plays it (left until one does: the reference path never reads them either)."""
        for v in range(len(self.graph.verbs)):
            for slot in (0, 1):
                if (v, slot) not in self._fresh:
                    try:
                        clocks._sampling(self.state, v, slot)
                    except AdverbsError:
                        continue
                    self._fresh.add((v, slot))

    def _refresh(self) -> None:
        """Bring up to date the caches this frame reads: slot A of the verbs playing and being entered, slot B of the
        verbs being entered and of those the queues start next (a transition may start this frame).

        Nothing to do while the adverbs hold still and every cache is fresh (the usual frame); once they stop moving,
        the caches no frame needed are brought up to date too, so later frames need not look."""
        state = self.state
        points = state.points
        same = self._seen is not None and points.ndim == 2 and self._same((self._seen, points), self._seen, points)
        if same and len(self._fresh) == self._pairs and state.cache_version == self._version:
            return
        if not same or state.cache_version != self._version:  # moved, or rows brought to other points in between
            self._fresh.clear()
            self._seen = points.copy()
        for pair in self._needed():
            if pair not in self._fresh:
                clocks._sampling(state, *pair)  # a point the verb refuses raises here, as on the reference path
                self._fresh.add(pair)
        if same:
            self._bring_up_to_date()
        self._version = state.cache_version

    def _needed(self) -> list[tuple[int, int]]:
        """The (verb, slot) caches this frame reads (see :meth:`_refresh`)."""
        state, n_v = self.state, len(self.graph.verbs)
        moving = state.active >= 0
        a = np.bincount(state.verb, minlength=n_v) > 0
        b = np.zeros(n_v, dtype=bool)
        if moving.any():
            b |= np.bincount(state.into[moving], minlength=n_v) > 0
            a |= b
        heads = state.head[~moving]
        heads = heads[heads >= 0]
        if len(heads):
            b |= np.bincount(self.tables.transitions[1][heads], minlength=n_v) > 0  # their targets
        return [(int(v), 0) for v in np.flatnonzero(a)] + [(int(v), 1) for v in np.flatnonzero(b)]

    def step(self, dt: float, plant: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Advance every creature by ``dt`` seconds; the rotations ``(C, J, 4)`` and translations ``(C, J, 3)`` shown
        (planted when ``plant`` and the pass has feet)."""
        dt = float(dt)
        if not (math.isfinite(dt) and dt > 0):
            raise AdverbsError(f"dt must be a positive number of seconds, got {dt}")
        state = self.state  # (the kernel adds dt to every creature's state.time, and gives it to the planter)
        self._refresh()
        first = state.moving is None
        if first:
            state.moving = np.zeros((state.creatures, 3))
        has_held_before = state.held_before is not None
        if not has_held_before:
            state.held_before = np.zeros(self.held.shape, dtype=bool)
        new, shown, before = self._turns
        poses = self._poses
        # The poses shown are the pass's own buffers (the usual frame), or the reference path's, copied in.
        has_shown = state.shown is poses[shown] or self._take(state.shown, shown)
        has_before = state.shown_before is poses[before] or self._take(state.shown_before, before)
        planting_on = plant and self.feet is not None
        start = False
        if planting_on:
            start = not self.feet.planter.started
            know_levels(self.feet, state)
        flags = (first, has_shown, has_before, has_held_before, start)
        turns = (new, shown, before, self._turn)
        planted = self._planted[self._turn]
        box = self._box()
        if planting_on:
            feet = self._feet()
            ranges = self._pool.run(self._planted_kernel, state.creatures, (dt, flags, turns, box, feet), (box, feet))
        else:
            ranges = self._pool.run(self._kernel, state.creatures, (dt, flags, turns, box), (box,))
        finite, events = True, 0
        for ok, n in ranges:
            finite, events = finite and ok, events + n
        if planting_on:
            self.feet.planter.started = True
        if events:
            self._events()
        self._turns = (before, new, shown)
        self._turn ^= 1
        state.shown_before, state.shown = state.shown, self._poses[new]
        state.alone, state.standing = self.alone, self.standing
        if not finite:
            raise AdverbsError("IK targets must be finite (got NaN or infinity)")
        return planted

    def _take(self, pose: tuple | None, k: int) -> bool:
        """Whether there is a ``pose`` (a frame shown); one the pass did not make (the reference path's) is copied into
        its buffer ``k``."""
        if pose is None:
            return False
        mine = self._poses[k]
        if pose is not mine:
            for a, b in zip(mine, pose):
                a[...] = b
        return True

    def _box(self) -> Held:
        """What the kernel reads and writes that stays put from frame to frame, held in one object (made again only
        when an array was replaced: the reference path replaces some)."""
        state = self.state
        arrays = (
            state.verb, state.g, state.into, state.g_into, state.active, state.beta, state.length, state.regions,
            state.time, state.inertial, state.rebase, state.offset_rot, state.offset_rot_vel, state.offset_trans,
            state.offset_trans_vel, state.offset_root, state.offset_since, state.offset_halflife, state.moving,
            state.root, state.held_before, state.arms_rot, state.arms_vel, state.arms_since, state.arms_of,
            state.arms_take, state.arms_length, state.lagging, state.arms_upper,
        )  # fmt: skip
        key = (state.head, *arrays)
        if self._box_key is not None and all(map(operator.is_, key, self._box_key)):
            return self._boxed
        t = self.tables
        outputs = (self.held, self.roll, self.swing, self.kinds, self.events, self.g_settle, self.lifts, self.eased)
        self._box_key = key
        self._boxed = hold((
            t.verbs, t.transitions, t.skeleton, self._caches, arrays, state.head, tuple(self._poses), outputs,
            self.constants, CHUNK, t.dofs, tuple(self._planted),
        ))  # fmt: skip
        return self._boxed

    def _feet(self) -> Held:
        """The planter's arrays as the kernel takes them, held (made again only when one was replaced)."""
        feet = self.feet
        p = feet.planter
        comp = p._compiled
        times, state = comp._times(), comp._state()
        key = (times, feet.replanting, feet.levels, feet.hover0, feet.level0, feet.pending, *state)
        if self._feet_key is not None and all(map(operator.is_, key, self._feet_key)):
            return self._feet_boxed
        self._feet_key = key
        self._feet_boxed = hold((
            comp.parents, comp.no_generic, self._inside, comp.dt, times, bool(p.verb.cyclic), float(p.verb.floor),
            comp.tips, comp.root, comp.legs, comp.constants, comp.floor, state, comp.chain, comp.ik_params,
            self._ik_out, self._drop, self._residual, feet.replanting, feet.levels, feet.hover0, feet.level0,
            feet.pending,
        ))  # fmt: skip
        return self._feet_boxed

    def _events(self) -> None:
        """The discrete half of the frame: queues of the creatures whose transition started or finished."""
        state = self.state
        rows = np.flatnonzero(self.events)
        for c in rows.tolist():
            if self.events[c] == kernel.STARTED:
                state.queue[c].pop(0)
                sync_head(state, c)
            else:
                graph_state._settle_queue(state, c, float(self.g_settle[c]))
                queue._arrived(state, c)
        self.events[rows] = 0


class Threads:
    """Ranges of creatures run on several threads at once (the kernels release the GIL): ``threads`` of them, default
    one per core (numba's count). Each range is a contiguous block of creatures; a crowd too small to share runs on
    the calling thread."""

    def __init__(self, threads: int | None = None):
        n = numba.config.NUMBA_NUM_THREADS if threads is None else int(threads)
        if n < 1:
            raise AdverbsError(f"threads must be at least 1, got {threads!r}")
        self.threads = n
        self._executor = None
        self._pid = 0  # the process that made the executor: a child forked from it has none of its threads

    def run(self, kernel, creatures: int, args: tuple, key: tuple = ()) -> list:
        """``kernel(lo, hi, *args)`` over ranges covering ``creatures``; the results in order. ``key``: passed on to
        an :class:`Entry` (what its arguments' types hang on)."""
        n = max(1, min(self.threads, creatures // PER_THREAD))
        call = functools.partial(kernel, key) if isinstance(kernel, Entry) else kernel  # call(lo, hi, *args)
        if n == 1:
            return [call(0, creatures, *args)]
        if self._executor is None or self._pid != os.getpid():  # (waiting on a parent's pool would never end)
            from concurrent.futures import ThreadPoolExecutor

            self._executor = ThreadPoolExecutor(self.threads, thread_name_prefix="adverbs-frame")
            self._pid = os.getpid()
        bounds = [creatures * k // n for k in range(n + 1)]
        futures = [self._executor.submit(call, bounds[k], bounds[k + 1], *args) for k in range(1, n)]
        first = call(bounds[0], bounds[1], *args)  # this thread takes the first range
        return [first] + [f.result() for f in futures]


class Entry:
    """A compiled kernel called straight through its compiled entry point once its argument types are known.

    numba's dispatcher finds the compiled version for a call's argument types by typing each argument in Python;
    for the pass's hundred arrays in nested tuples that costs about 200 µs a call, more than a small crowd's frame.
    The types change only when the arrays passed do (``key``: the objects they hang on, compared by identity), so
    the first call with a new key goes through the dispatcher (compiling, or loading numba's cache) and the
    version it chose is called directly after that.
    """

    def __init__(self, dispatcher):
        self.dispatcher = dispatcher
        self._key: tuple | None = None
        self._entry = None

    def __call__(self, key: tuple, *args):
        if self._entry is not None and len(key) == len(self._key) and all(map(operator.is_, key, self._key)):
            return self._entry(*args)
        result = self.dispatcher(*args)
        found = self.dispatcher.overloads.get(tuple(numba.typeof(a) for a in args))
        self._key, self._entry = (key, found.entry_point) if found is not None else (None, None)
        return result
