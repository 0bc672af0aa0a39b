"""Time in a verb graph (§5): generic and clock times of each creature's verbs under its own keytimes, the
verbs' cached weights, keytimes and hold times per creature (slot 0: the verb playing, A; slot 1: the one being
entered, B), and where a transition puts A and B: each clock runs through its region as ``β`` goes from 0 to 1.

A transition lasts the mean of its two regions' lengths in clock time at the current adverbs (:func:`duration`),
and each verb's clock runs through its region at its own rate (:func:`_rates`), which scales its root velocities.
"""

from __future__ import annotations


import numpy as np

from ..kinematics import quat
from ..verb.sampling import SamplingState
from ._time_kernel import clock_rows, generic_rows, later_rows
from .state import MOST_PACED, PACE, PLACE_PACE, GraphState


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


PACED_AT = np.array([0.25, 0.5, 0.75])  # where in a blend paced_length compares the verbs' poses (β)


def paced_length(
    state: GraphState, c: int, k: int, regions: tuple[float, float, float, float], caches: tuple | None = None
) -> float:
    """The least length (seconds) of creature ``c``'s cosine blend through transition ``k`` over ``regions`` ``(sa,
    ea, sb, eb)`` (generic times) for no part of :attr:`Graph.paced` to turn faster, by the blending alone, than
    :data:`PACE` times its own fastest in the two verbs, nor, between two verbs that stand on their feet
    (``DofEncoding.anchored``), the hips to move from over one's stance to over the other's faster than
    :data:`PLACE_PACE` times their own fastest (:func:`~adverbs.verb.tables.body_place`), up to :data:`MOST_PACED`.

    The blend turns a joint at ``α'(β) θ(β)``, ``θ`` the angle between the verbs' poses and ``α' = π sin(βπ) / 2T``
    over ``T`` seconds. ``θ`` is measured at ``β`` = :data:`PACED_AT` (A and B at those fractions of their regions,
    by generic time, at the creature's adverbs); ``ω``, the part's own fastest at the creature's weights
    (``Graph.own_speeds``), the larger of A's and B's: ``T = π max(sin(βπ) θ / ω) / (2 PACE)``. The frame kernel's
    ``_paced``, the same. ``caches``: A's and B's :class:`SamplingState` (slots 0 and 1), up to date, if the caller
    has them."""
    from ..verb.sampling import GENERIC, run_kernel  # (sampling imports the verbs' kernel: kept out of import time)

    graph = state.graph
    t = graph.transitions[k]
    sa, ea, sb, eb = regions
    rows = np.full(len(PACED_AT), c, dtype=np.int64)
    from ..kinematics.fk import forward_kinematics
    from ..verb.tables import body_place

    # The hips move over the feet in a blend only where both verbs stand on them: their place is read only then.
    placed = graph.verbs[t.source].encoding.anchored and graph.verbs[t.target].encoding.anchored
    rot, place, omega = [], [np.zeros((len(PACED_AT), 2))] * 2, []
    if caches is None:
        caches = (_sampling(state, t.source, 0), _sampling(state, t.target, 1))
    for i, (v, cache, s, e) in enumerate(((t.source, caches[0], sa, ea), (t.target, caches[1], sb, eb))):
        verb = graph.verbs[v]
        d = run_kernel(verb, cache, rows, np.clip(s + PACED_AT * (e - s), 0.0, 1.0), GENERIC)
        r, tr = verb.encoding.decode_pose(d, np.zeros(3))
        rot.append(r)
        if placed:
            place[i] = body_place(verb.encoding, forward_kinematics(graph.skeleton.parents, r, tr)[0])
        omega.append(graph.own_speeds(v, cache.weights[c]))
    apart = np.c_[quat.angle(rot[0], rot[1]), np.linalg.norm(place[0] - place[1], axis=-1)]  # (β, J + 1)
    turn = apart * np.sin(np.pi * PACED_AT)[:, None]
    own = np.maximum(omega[0], omega[1])
    parts = [*graph.paced, np.array([graph.skeleton.num_joints])]  # ... and the body's place (Graph.paced_joints)
    parts = parts if placed else parts[:-1]
    pace = [PACE] * len(graph.paced) + [PLACE_PACE]
    need = max(float(turn[:, p].max()) / max(float(own[i]), 1e-9) / pace[i] for i, p in enumerate(parts))
    return min(0.5 * np.pi * need, MOST_PACED)


def _sampling(state: GraphState, v: int, slot: int) -> SamplingState:
    """Verb ``v``'s cached weights and keytimes for every creature, in slot 0 (A) or 1 (B), up to date."""
    graph = state.graph
    verb = graph.verbs[v]
    key = (v, slot)
    s = state.caches.get(key)
    if s is None:
        s = state.caches[key] = SamplingState.new(verb, state.creatures)
    if state.fresh is None or key not in state.fresh:  # within a step the adverbs hold still: once is enough
        changed = s.update(verb, graph.verb_points(v, state.points))
        if changed:  # (what is kept beside the weights, in place: the compiled frame holds on to the arrays)
            state.cache_version += 1
            carry = state.caches.get((key, "carry"))
            if carry is None:
                state.caches[key, "carry"] = np.full(state.creatures, np.nan)
            else:  # worked out again where a frame needs it (_carry)
                carry[...] = np.nan
        if changed and verb.holds:
            times = verb.hold_times(s.weights)  # when each creature's feet land and lift
            held = state.caches.get((key, "holds"))
            if held is None:
                state.caches[key, "holds"] = times
            else:
                held[...] = times
        if state.fresh is not None:
            state.fresh.add(key)
    return s


def _hold_times(state: GraphState, v: int, slot: int) -> np.ndarray:
    """Verb ``v``'s hold times ``(C, L, 3)`` at every creature's adverbs in slot 0 (A) or 1 (B) (see :meth:`Verb.hold_times`)."""
    _sampling(state, v, slot)
    return state.caches[(v, slot), "holds"]


def _carry(state: GraphState, v: int, slot: int, rows: np.ndarray) -> np.ndarray:
    """Verb ``v``'s carry limit ``(n,)`` at the adverbs of creatures ``rows`` in slot 0 (A) or 1 (B) (see
    :meth:`Verb.carry_limit`): kept, NaN since a creature's adverbs last moved until a frame needs it, then worked
    out and kept (here, or by the compiled frame)."""
    s = _sampling(state, v, slot)
    kept = state.caches[(v, slot), "carry"]
    todo = rows[np.isnan(kept[rows])]
    if len(todo):
        kept[todo] = state.graph.verbs[v].carry_limit(s.weights[todo], s.keytimes[todo])
    return kept[rows]


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
