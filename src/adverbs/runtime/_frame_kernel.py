"""The one compiled pass of a frame: every creature of a group, from its clocks to its planted pose.

:func:`frame` is :func:`adverbs.graph.player.step` followed by :func:`adverbs.graph.planted.plant` (the readable
path, which stays the reference) for every creature at once, with no Python per creature: clocks (a verb alone
by its own, a transition by ``β``; a transition starting or finishing where the region says) → the verbs
sampled (one, or two in a blend) → root velocities blended → root advanced → poses decoded and blended → the
decaying offsets of inertial blends and interruptions → the arms (a start: the upper body) carried past a short
blend → hold phases → the body carried by the held feet → the
feet planted (the planter's own kernel, :func:`adverbs.feet._planting_kernel.step`) → feet to re-place.

Each piece calls the same compiled arithmetic the reference path calls (the sampling query, the decode, the
slerp blend, the spring, FK), creature by creature, so a frame equals the reference's to rounding;
``tests/test_frame.py`` holds them together over a long seeded run. Creatures are independent: each thread of
:class:`~adverbs.runtime.frame.FramePass` runs its own range of them (the kernel releases the GIL), chunk by
chunk, and the results do not depend on how many threads run them.

**No reference counting per creature.** The functions run once or more per creature or chunk (:func:`_creature`,
:func:`_advance`, :func:`_base`, :func:`_start`, :func:`_finish`, :func:`_arms_take`, :func:`_chunk`, :func:`_plant`)
are compiled without numba's reference counting (``_nrt=False``): they allocate nothing, and every array they see
is one their caller keeps alive (the pass's held arrays, borrowed: ``_borrow_kernel``; the working buffer
:func:`_frame` allocates once a call and carves: ``_scratch_kernel``). With
it, numba counted each of the hundred-odd arrays in their arguments in and out at every call and every view taken
(calls to ``NRT_incref``/``NRT_decref`` on null meminfos, about a thousand call sites in :func:`_creature`). The
planter's per-creature loops (``_planting_kernel._step``, ``_advance``, ``_reach`` and its per-foot helpers), the
IK's (``_ik_kernel._solve_batch``, whose array expressions allocated a temporary per leg and iteration) and FK's
``forward`` are compiled so too. With the counting, 10,000 Bandai creatures on one thread took 10-12 µs each
unplanted and 16-18 planted; without it 5.2-5.4 and 9.8-11.2 (session 53; ``benchmarks/crowd.py`` in the README).
A function added here that allocates, or copies a slice (which may allocate a temporary), must keep the counting:
numba refuses to compile it without. numba passes the flag on to the functions they call that do not set their
own, so the planter's and the IK's functions that allocate say ``_nrt=True``; and no function they call uncounted
may return an array (its caller would count the view it did not). numba's cache keys a compiled function by its
signature, not this flag: a function compiled without counting may be loaded where counting is on, which is the
same for one that allocates nothing and returns no array.

What stays in Python (:mod:`adverbs.runtime.frame`) is discrete: commands, the queue (a transition popped
when one starts, drawn by likelihood when it empties), latencies, and the verbs' cached weights and keytimes
brought up to date when the adverbs move. The kernel marks in ``events`` which creatures started (1) or
finished (2) a transition this frame, for Python to settle their queues.

Arguments come in tuples (``frame.FramePass`` lays them out once):

* ``verbs``, per verb, where shapes differ a flat array and its offsets (verb ``v``'s part is
  ``flat[off[v]:off[v + 1]]``): ``segments`` ``(NumCP, E, D)`` (flat, offsets, shapes ``(V, 3)``), ``generic``
  ``(N,)``, ``cyclic (V,)``, ``goal_columns``, ``goal_window (V, 3)``, the log-quaternion decode (``rotated``,
  ``reference (V, J, 4)``, ``translated``, ``base (V, J, 3)``, ``body (V,)``, ``has_parent (V,)``, ``parent_inv
  (V, 4)``, ``parent_pos (V, 3)``), the holds (``opens``, ``cols`` in the graph's feet, ``has_holds (V,)``) and
  the examples' foot lifts (``Verb.lift_table`` ``(3, E, S + 1, L)``: flat, offsets, shapes ``(V, 3)`` of
  ``(E, S + 1, L)``), the examples' fastest root accelerations (``Verb.root_accelerations`` ``(E,)``: flat,
  offsets) and their root velocities through their cycle (``Verb.root_velocity_samples`` ``(E, S, 3)``: flat,
  offsets).
* ``transitions``: ``regions (T, 4)`` (source start and end, target start and end), ``target (T,)``,
  ``inertial (T,)``, ``between (T,)`` (from one verb to another), ``arms (T,)`` (what it carries on past its blend:
  ``Graph.carries_arms``).
* ``skeleton``: ``parents (J,)``, the graph's feet ``(L,)``, the inverse rest rotation above the body root ``(4,)``,
  the body root, the joints a blend may carry on ``(U,)`` (``Graph.carried``: the arms first), the parts the paced
  blends read, the feet's ancestors, the stance joints, and how many of the carried joints are the arms.
* ``caches = (tables, offsets)``: each creature's ``weights``, ``keytimes``, ``seam``, ``goal``, hold times and
  carry limit (``Verb.carry_limit``) of every verb, one ``(C, Σ)`` table per kind and slot (slot 0 the verb playing,
  1 the one being entered: ``tables = (W0, W1, K0, K1, S0, S1, G0, G1, H0, H1, L0, L1)``), verb ``v``'s columns
  given by ``offsets`` (one array per kind). The verbs' :class:`~adverbs.verb.sampling.SamplingState` rows are views
  of these tables, so the reference path and the pass read and write the same numbers.
* ``state``: :class:`~adverbs.graph.state.GraphState`'s arrays, updated in place.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .._scratch_kernel import carve, keep
from ..graph._blend_kernel import decay_row, keep_feet_row
from ._borrow_kernel import borrowed_box
from ..graph._time_kernel import _clock, _generic
from ..motion._pose_kernel import _exp, _log, _mul, _rotate, advance_root_row, blend_row, decode_row, root_velocity_row
from ..feet._planting_kernel import step as plant_step
from ..feet._planting_scalars import hold_mode, smoothstep, spring
from ..verb._sampling_kernel import GENERIC, VELOCITIES, goal_weight, phase, query_into

STARTED, FINISHED = 1, 2  # events: a transition started, or finished, this frame
FREE, BALL = 0, 2  # planting.FREE, planting.BALL
# Where each constant sits in ``k_`` (see frame.FramePass).
(_LATE, _MIN_DURATION, _INERTIAL, _LN2, _REPLANT, _REPLANTED, _SWING, _LIFT, _LANDS, _LEFT_BEHIND, _RISE, _DELAY, _LAND, _MIN_LOOP,
 _STANDING, _SHIFTED, _SWING_LIFT, _ARMS, _PACE, _MOST_PACED, _STOPPING, _SETTLING, _FRAME, _PLACE_PACE) = range(24)


# ----- the tables, packed: per verb, a slice of a flat array (see frame.tables and FramePass) ------------------


@njit(cache=True, inline="always")
def _held(hbox):  # pragma: no cover - compiled
    """What a creature's functions read of the pass's held arrays (:func:`frame`'s ``box``), borrowed: ``(verbs,
    transitions, skeleton, caches, state, head, outputs, k_)``. They are given the ``Held`` itself, one pointer, and
    read the arrays they use from it: given the tuples, each call copied some 1,500 words of array structures onto
    the stack (``_chunk``, which does little but call :func:`_creature`, was 6% of a 10,000-creature frame)."""
    box = borrowed_box(hbox)
    return box[0], box[1], box[2], box[3], box[4], box[5], box[7], box[8]


@njit(cache=True, inline="always")
def _buffers(hbox, turns):  # pragma: no cover - compiled
    """The pose buffers of a frame by ``turns`` (see :func:`frame`): ``(rot, trans, vel)`` new, rotations and
    translations shown, shown before, velocities shown (what :func:`_creature` calls ``buffers``); and the planted pair
    written, ``(rot, trans)``."""
    box = borrowed_box(hbox)
    poses, planted = box[6], box[11]
    new, shown, before = poses[turns[0]], poses[turns[1]], poses[turns[2]]
    return (new[0], new[1], new[2], shown[0], shown[1], before[0], before[1], shown[2]), planted[turns[3]]


@njit(cache=True, inline="always")
def _sizes(hbox):  # pragma: no cover - compiled
    """A creature's DOFs, joints and feet, ``(D, J, L)``: what its working arrays are sized by (:func:`_scratch`)."""
    box = borrowed_box(hbox)
    return box[10], box[6][0][0].shape[1], box[2][1].shape[0]


@njit(cache=True, inline="always")
def _working(hbox, buf, hb):  # pragma: no cover - compiled
    """:func:`_creature`'s working arrays, carved from ``buf`` (:func:`_scratch_size` long) and ``hb (L,)`` (a view
    each: cheaper than passing two dozen array structures by value to every creature)."""
    n_d, n_j, n_l = _sizes(hbox)
    return _scratch(buf, hb, n_d, n_j, n_l)


@njit(cache=True, inline="always")
def _part(flat, off, v):  # pragma: no cover - compiled
    """Verb ``v``'s part of a flat table: ``flat[off[v]:off[v + 1]]``."""
    return flat[off[v] : off[v + 1]]


@njit(cache=True, inline="always")
def _segments(verbs, v):  # pragma: no cover - compiled
    """Verb ``v``'s control points / 6, ``(NumCP, E, D)``."""
    shape = verbs[2]
    return _part(verbs[0], verbs[1], v).reshape((shape[v, 0], shape[v, 1], shape[v, 2]))


@njit(cache=True, inline="always")
def _generic_keys(verbs, v):  # pragma: no cover - compiled
    """Verb ``v``'s generic keytimes ``(N,)``."""
    return _part(verbs[3], verbs[4], v)


@njit(cache=True, inline="always")
def _columns(caches, slot, v, which):  # pragma: no cover - compiled
    """Verb ``v``'s columns ``(C, ·)`` of cache ``which`` (0 weights, 1 keytimes, 2 seam, 3 goal, 4 hold times, 5 carry
    limit) in ``slot``."""
    off = caches[1][which]
    return caches[0][2 * which + slot][:, off[v] : off[v + 1]]


@njit(cache=True, inline="always")
def _keys(caches, v, slot, c):  # pragma: no cover - compiled
    """Creature ``c``'s keytimes ``(N,)`` of verb ``v`` in ``slot``."""
    return _columns(caches, slot, v, 1)[c]


@njit(cache=True, inline="always")
def _clock_of(g, v, slot, c, verbs, caches):  # pragma: no cover - compiled
    """``clocks._clock``: clock time of generic time ``g`` of creature ``c`` in verb ``v`` (slot)."""
    generic = _generic_keys(verbs, v)
    return _clock(g, _keys(caches, v, slot, c), generic, generic.shape[0])


@njit(cache=True, inline="always")
def _generic_of(clock, v, slot, c, verbs, caches):  # pragma: no cover - compiled
    """``clocks._generic``: the inverse of :func:`_clock_of`."""
    generic = _generic_keys(verbs, v)
    return _generic(clock, _keys(caches, v, slot, c), generic, generic.shape[0])


@njit(cache=True, inline="always")
def _later(g, seconds, v, slot, c, verbs, caches):  # pragma: no cover - compiled
    """``clocks._later``: the generic time ``seconds`` of the creature's clock after ``g``."""
    generic = _generic_keys(verbs, v)
    keys = _keys(caches, v, slot, c)
    n = generic.shape[0]
    return _generic(_clock(g, keys, generic, n) + seconds, keys, generic, n)


@njit(cache=True, inline="always")
def _region_clocks(c, verbs, caches, state):  # pragma: no cover - compiled
    """``clocks._region_clocks``: clock times of the start and end of A's region and of B's."""
    verb, into, regions = state[0], state[2], state[7]
    a, b = verb[c], into[c]
    return (
        _clock_of(regions[c, 0], a, 0, c, verbs, caches), _clock_of(regions[c, 1], a, 0, c, verbs, caches),
        _clock_of(regions[c, 2], b, 1, c, verbs, caches), _clock_of(regions[c, 3], b, 1, c, verbs, caches),
    )  # fmt: skip


@njit(cache=True, inline="always")
def _rates(c, verbs, caches, state):  # pragma: no cover - compiled
    """``clocks._rates``: how fast A's and B's clocks run in creature ``c``'s transition."""
    ca0, ca1, cb0, cb1 = _region_clocks(c, verbs, caches, state)
    length = state[6][c]
    rate_b = 1.0 if state[9][c] else (cb1 - cb0) / length
    return (ca1 - ca0) / length, rate_b


@njit(cache=True, inline="always")
def _place(c, verbs, caches, state):  # pragma: no cover - compiled
    """``clocks._place``: A and B of creature ``c`` where ``β`` says, each clock through its region."""
    verb, g, into, g_into, beta, length, inertial = state[0], state[1], state[2], state[3], state[5], state[6], state[9]
    ca0, ca1, cb0, cb1 = _region_clocks(c, verbs, caches, state)
    b = beta[c]
    g[c] = _generic_of(ca0 + b * (ca1 - ca0), verb[c], 0, c, verbs, caches)
    run = length[c] if inertial[c] else cb1 - cb0
    g_into[c] = _generic_of(cb0 + b * run, into[c], 1, c, verbs, caches)


@njit(cache=True, inline="always")
def _own_speeds(v, slot, c, verbs, caches, part_of, out):  # pragma: no cover - compiled
    """``Graph.own_speeds`` of creature ``c``'s verb ``v`` (in ``slot``) into ``out[:P]``: its examples' joint speeds
    blended with its weights at each generic time, each paced part's fastest, kept within the examples' own."""
    profile, bounds, dims = _part(verbs[31], verbs[32], v), _part(verbs[33], verbs[34], v), verbs[35]
    n_e, n_s, n_j = dims[v, 0], dims[v, 1], dims[v, 2]
    n_p = out.shape[0]
    w = _columns(caches, slot, v, 0)[c]
    for p in range(n_p):
        out[p] = -np.inf
    for s in range(n_s):
        for j in range(n_j):
            p = part_of[j]
            if p < 0:
                continue
            acc = 0.0
            for e in range(n_e):
                acc += w[e] * profile[(e * n_s + s) * n_j + j]
            out[p] = max(out[p], acc)
    for p in range(n_p):
        lo, hi = np.inf, -np.inf
        for e in range(n_e):
            lo, hi = min(lo, bounds[e * n_p + p]), max(hi, bounds[e * n_p + p])
        out[p] = min(max(out[p], lo), hi)


@njit(cache=True, inline="always")
def _anchored(verbs, v):  # pragma: no cover - compiled
    """Whether verb ``v`` stands on its feet (``DofEncoding.anchored``: its body root has translation columns)."""
    translated, body = _part(verbs[12], verbs[13], v), verbs[15][v]
    for k in range(translated.shape[0]):
        if translated[k] == body:
            return True
    return False


@njit(cache=True, inline="always")
def _global_position(parents, rot, trans, j):  # pragma: no cover - compiled
    """Joint ``j``'s global position in a pose of local ``rot (J, 4)``, ``trans (J, 3)``: up its chain."""
    px, py, pz = trans[j, 0], trans[j, 1], trans[j, 2]
    k = parents[j]
    while k >= 0:
        px, py, pz = _rotate(rot[k, 0], rot[k, 1], rot[k, 2], rot[k, 3], px, py, pz)
        px, py, pz = px + trans[k, 0], py + trans[k, 1], pz + trans[k, 2]
        k = parents[k]
    return px, py, pz


@njit(cache=True, inline="always")
def _stance_place(parents, rot, trans, body, stance):  # pragma: no cover - compiled
    """``tables.body_place`` of one pose: the body root across the floor (x, z) less the mean of ``stance``'s."""
    bx, _, bz = _global_position(parents, rot, trans, body)
    sx, sz = 0.0, 0.0
    for i in range(stance.shape[0]):
        x, _, z = _global_position(parents, rot, trans, stance[i])
        sx += x
        sz += z
    return bx - sx / stance.shape[0], bz - sz / stance.shape[0]


@njit(cache=True, _nrt=False)
def _paced(c, k, sa, ea, sb, eb, hbox, buf, hb):  # pragma: no cover - compiled
    """``clocks.paced_length`` of creature ``c``'s blend through transition ``k`` over the regions ``(sa, ea, sb,
    eb)``; sampled into the creature's working arrays (:func:`_working`: free while its times move on)."""
    verbs, transitions, skeleton, caches, state, _, _, k_ = _held(hbox)
    scratch = _working(hbox, buf, hb)
    d, r1, r2, blend, rot_a, trans_a, rot_b, trans_b = (
        scratch[2], scratch[6], scratch[7], scratch[8], scratch[11], scratch[12], scratch[22], scratch[23]
    )  # fmt: skip
    part_of, body = skeleton[5], skeleton[3]  # part_of's last entry: the body's place (Graph.paced_joints)
    source, target = state[0][c], transitions[1][k]
    n_p = 0
    for j in range(part_of.shape[0]):
        n_p = max(n_p, part_of[j] + 1)
    own, other = r1[:n_p], r2[:n_p]
    _own_speeds(source, 0, c, verbs, caches, part_of, own)
    _own_speeds(target, 1, c, verbs, caches, part_of, other)
    for p in range(n_p):
        own[p] = max(max(own[p], other[p]), 1e-9)
    placed = _anchored(verbs, source) and _anchored(verbs, target)  # both stand on their feet: the hips move over them
    need = 0.0
    for i in range(3):  # clocks.PACED_AT
        b = 0.25 * (i + 1)
        scale = math.sin(np.pi * b)
        _dofs(d, source, 0, c, min(max(sa + b * (ea - sa), 0.0), 1.0), verbs, caches, blend)
        _decode_verb(source, d, 0.0, 0.0, 0.0, verbs, rot_a, trans_a)
        _dofs(d, target, 1, c, min(max(sb + b * (eb - sb), 0.0), 1.0), verbs, caches, blend)
        _decode_verb(target, d, 0.0, 0.0, 0.0, verbs, rot_b, trans_b)
        n_j = rot_a.shape[0]
        for j in range(n_j):
            p = part_of[j]
            if p < 0:
                continue
            dot = abs(rot_a[j, 0] * rot_b[j, 0] + rot_a[j, 1] * rot_b[j, 1] + rot_a[j, 2] * rot_b[j, 2]
                      + rot_a[j, 3] * rot_b[j, 3])  # fmt: skip
            need = max(need, 2.0 * math.acos(min(dot, 1.0)) * scale / own[p] / k_[_PACE])
        if placed:
            ax, az = _stance_place(skeleton[0], rot_a, trans_a, body, skeleton[7])
            bx, bz = _stance_place(skeleton[0], rot_b, trans_b, body, skeleton[7])
            apart = math.sqrt((ax - bx) ** 2 + (az - bz) ** 2)
            need = max(need, apart * scale / own[part_of[n_j]] / k_[_PLACE_PACE])
    return min(0.5 * np.pi * need, k_[_MOST_PACED])


@njit(cache=True, _nrt=False)
def _start(c, late, k, hbox, buf, hb):  # pragma: no cover - compiled
    """``queue._start``: creature ``c`` starts transition ``k``; ``late``: seconds of this frame left after its region
    began. (Python pops it off the queue afterwards.) ``buf``, ``hb``: the creature's working arrays (:func:`_paced`)."""
    verbs, transitions, _, caches, state, _, _, k_ = _held(hbox)
    verb, g, into, g_into, active, beta, length, regions = state[:8]
    inertial, rebase, halflife = state[9], state[10], state[17]
    t_regions, t_target, t_inertial = transitions[0], transitions[1], transitions[2]
    source, target = verb[c], t_target[k]
    sa, ea, sb, eb = t_regions[k, 0], t_regions[k, 1], t_regions[k, 2], t_regions[k, 3]
    gc = g[c]
    whole = False  # B's region played whole, at no more than its own speed (queue._start)
    if gc > sa + k_[_LATE]:  # the region has begun already (a one-shot verb past it, or a loop begun late)
        if not verbs[5][source]:
            sa, ea, whole = gc, max(ea, gc), True
        elif gc < ea:
            sb += (gc - sa) / (ea - sa) * (eb - sb)
            sa = gc
        else:
            sa = ea = gc
    if verbs[5][target] and eb >= 1.0:  # B plays the end of its previous cycle
        sb, eb = sb - 1.0, eb - 1.0
    length_a = _clock_of(ea, source, 0, c, verbs, caches) - _clock_of(sa, source, 0, c, verbs, caches)
    length_b = _clock_of(eb, target, 1, c, verbs, caches) - _clock_of(sb, target, 1, c, verbs, caches)
    duration = 0.5 * (length_a + length_b)
    if whole:  # not shorter than B's region; a cosine blend as long as begun where A's region begins
        duration = max(duration, length_b)
    if whole and not t_inertial[k]:
        whole_a = (_clock_of(t_regions[k, 1], source, 0, c, verbs, caches)
                   - _clock_of(t_regions[k, 0], source, 0, c, verbs, caches))  # fmt: skip
        duration = max(duration, 0.5 * (whole_a + length_b))
    if not t_inertial[k] and transitions[5][k]:  # long enough for no part to turn too fast by the blend alone
        duration = max(duration, _paced(c, k, sa, ea, sb, eb, hbox, buf, hb))
    active[c], into[c] = k, target
    regions[c, 0], regions[c, 1], regions[c, 2], regions[c, 3] = sa, ea, sb, eb
    length[c] = max(duration, k_[_MIN_LOOP] if source == target else k_[_MIN_DURATION])  # a loop: what is left
    beta[c] = min(late / length[c], 1.0)
    g_into[c] = sb
    inertial[c] = t_inertial[k]
    if inertial[c]:  # B at once, the pose shown decaying onto it
        rebase[c] = True
        halflife[c] = max(k_[_INERTIAL] * length[c], 0.0)
    elif transitions[4][k] == 2 or ((transitions[4][k] == 1 or transitions[4][k] == 3) and length[c] < k_[_ARMS]):
        # the arms (a start: the upper body; again while a start's offset of it is alive) carried on (queue._start)
        alive = state[28][c] and state[23][c] < state[26][c]
        state[28][c] = transitions[4][k] == 3 or alive
        state[25][c], state[26][c] = True, length[c] if transitions[4][k] == 2 else k_[_ARMS]


@njit(cache=True, _nrt=False)
def _finish(c, hbox):  # pragma: no cover - compiled
    """``queue._finish`` without the queue (Python settles it): B plays on alone."""
    verbs, _, _, _, state, _, _, _ = _held(hbox)
    verb, g, into, g_into, active = state[0], state[1], state[2], state[3], state[4]
    verb[c], g[c] = into[c], g_into[c]
    if g[c] < 0.0 and abs(g[c]) < 1e-9:
        g[c] = 0.0
    if not verbs[5][verb[c]]:
        g[c] = min(g[c], 1.0)
    elif g[c] >= 1.0:  # a blend turned back ran a cycle past its end: on in the next
        g[c] -= math.floor(g[c])
    active[c], into[c] = -1, -1


@njit(cache=True, _nrt=False)
def _advance(c, dt, hbox, buf, hb):  # pragma: no cover - compiled
    """``player._advance`` for creature ``c``: its times moved on by ``dt``, transitions started and finished (``buf``,
    ``hb``: its working arrays, for :func:`_start`)."""
    verbs, transitions, _, caches, state, head, outputs, k_ = _held(hbox)
    events, g_settle = outputs[4], outputs[5]
    verb, g, active, beta, length = state[0], state[1], state[4], state[5], state[6]
    moving = active[c] >= 0
    if moving:
        beta[c] += dt / length[c]
    else:
        v = verb[c]
        g_new = _later(g[c], dt, v, 0, c, verbs, caches)
        k = head[c]  # the queue's first transition (Python keeps it: never none for a verb playing alone)
        nxt = transitions[0][k, 0] if k >= 0 else np.inf
        begins = g_new >= nxt - k_[_LATE]
        if not verbs[5][v]:
            g_new = min(g_new, 1.0)
        if begins:
            clock = _clock_of(g[c], v, 0, c, verbs, caches) + dt
            at = _clock_of(max(nxt, g[c]), v, 0, c, verbs, caches)
            g[c] = max(nxt, min(g[c], 1.0))
            _start(c, max(clock - at, 0.0), k, hbox, buf, hb)
            events[c] = STARTED
        else:
            g[c] = g_new
    if moving and beta[c] >= 1.0:  # the transition ends this frame
        over = (beta[c] - 1.0) * length[c]
        beta[c] = 1.0
        _place(c, verbs, caches, state)
        _finish(c, hbox)
        events[c] = FINISHED
        g_settle[c] = g[c]
        if over > 0:  # the rest of the frame, B alone
            g[c] = _later(g[c], over, verb[c], 0, c, verbs, caches)
    if active[c] >= 0:
        _place(c, verbs, caches, state)


@njit(cache=True, inline="always")
def _dofs(out, v, slot, c, g, verbs, caches, blend):  # pragma: no cover - compiled
    """``player._dofs`` of one creature: verb ``v``'s DOFs at generic time ``g`` (another cycle's shifted by the seam)
    into ``out[:D]``."""
    segments, generic, goal_window = _segments(verbs, v), _generic_keys(verbs, v), verbs[8][v]
    seam = _columns(caches, slot, v, 2)[c]
    nd = segments.shape[2]
    lap = math.floor(g) if verbs[5][v] else 0.0  # a one-shot at its end (g = 1) shows its last pose, not its first
    local = min(max(g - lap, 0.0), 1.0)
    # Generic times: no cycle, so no seam fade (its window is not read).
    seg, fade, vfade, _, t = phase(_columns(caches, slot, v, 1), generic, c, local, GENERIC, 0.0, segments.shape[0],
                                   blend)  # fmt: skip
    columns = _part(verbs[6], verbs[7], v)
    reach = goal_weight(goal_window, t) if columns.shape[0] > 0 else 0.0
    query_into(out[:nd], segments, _columns(caches, slot, v, 0)[c], seg, blend, seam, fade, vfade,
               min(VELOCITIES, nd), reach, _columns(caches, slot, v, 3)[c], columns)  # fmt: skip
    if verbs[5][v]:
        for d in range(VELOCITIES, nd):
            out[d] += lap * seam[d]


@njit(cache=True, inline="always")
def _blend_weight(beta):  # pragma: no cover - compiled
    """``clocks.blend_weight`` of one creature: A's weight ``α = 0.5 cos(βπ) + 0.5``, β clipped to [0, 1]."""
    return 0.5 * math.cos(min(max(beta, 0.0), 1.0) * np.pi) + 0.5


@njit(cache=True, _nrt=False)
def _base(c, ga, gb, hbox, d_a, d_b, vel, blend):  # pragma: no cover - compiled
    """``player._sample`` of one creature at A's and B's generic times: DOFs into ``d_a``, ``d_b``, the blended root
    velocities into ``vel (3,)``; returns A's blend weight ``α`` (1 alone, 0 inertial)."""
    verbs, _, _, caches, state, _, _, _ = _held(hbox)
    verb, into, active, beta, inertial = state[0], state[2], state[4], state[5], state[9]
    moving = active[c] >= 0
    inert = moving and inertial[c]
    rate_a, rate_b, alpha = 1.0, 1.0, 1.0
    if moving:
        rate_a, rate_b = _rates(c, verbs, caches, state)
        if state[7][c, 0] == state[7][c, 1] and not verbs[5][verb[c]]:
            rate_a = 1.0  # a one-shot waiting at its end: its body goes on at its last velocity (player._sample)
        alpha = 0.0 if inert else _blend_weight(beta[c])
        _dofs(d_b, into[c], 1, c, gb, verbs, caches, blend)
    vel[0], vel[1], vel[2] = 0.0, 0.0, 0.0
    if not inert:
        _dofs(d_a, verb[c], 0, c, ga, verbs, caches, blend)
        w = alpha * rate_a
        for a in range(3):
            vel[a] += w * d_a[a]
    if moving:
        w = (1.0 - alpha) * rate_b
        for a in range(3):
            vel[a] += w * d_b[a]
        if gb < 0.0:  # B playing its previous cycle: its velocities' seam taken off (player._seam_rise)
            b = beta[c]
            u = 1.0 - (1.0 - b) ** 2 * (1.0 + 2.0 * b) - 3.0 * b * (1.0 - b)
            seam = _columns(caches, 1, into[c], 2)[c]
            w = u * rate_b
            for a in range(3):
                vel[a] -= w * seam[a]
    return alpha


@njit(cache=True, inline="always")
def _decode(c, x, z, heading, alpha, verbs, state, d_a, d_b, rot, trans, rot_b, trans_b):  # pragma: no cover
    """``player._decode`` of one creature at the root ``(x, z, heading)``: A and B decoded, then blended."""
    verb, into, active, inertial = state[0], state[2], state[4], state[9]
    moving = active[c] >= 0
    if not (moving and inertial[c]):
        _decode_verb(verb[c], d_a, x, z, heading, verbs, rot, trans)
    if moving:
        _decode_verb(into[c], d_b, x, z, heading, verbs, rot_b, trans_b)
        blend_row(rot, trans, rot_b, trans_b, alpha)


@njit(cache=True, inline="always")
def _decode_verb(v, d, x, z, heading, verbs, rot, trans):  # pragma: no cover - compiled
    decode_row(
        d, x, z, heading, _part(verbs[9], verbs[10], v), verbs[11][v], _part(verbs[12], verbs[13], v), verbs[14][v],
        verbs[15][v], verbs[17][v], verbs[18][v], verbs[16][v], rot, trans,
    )  # fmt: skip


@njit(cache=True, inline="always")
def _relative_into(a, b, out):  # pragma: no cover - compiled
    """``player._relative`` of one joint: the rotation vector of ``a b⁻¹`` the short way round, into ``out (3,)``."""
    x, y, z, w = _mul(a[0], a[1], a[2], a[3], -b[0], -b[1], -b[2], b[3])
    if w < 0.0:
        x, y, z, w = -x, -y, -z, -w
    out[0], out[1], out[2] = _log(x, y, z, w)


@njit(cache=True, inline="always")
def _phases(v, slot, c, g, verbs, caches, held, roll, swing, lifts):  # pragma: no cover - compiled
    """``player.hold_phases`` of one verb instance: its holds at generic time ``g`` into the graph's feet columns,
    and the examples' lifts of its feet there (``planter.example_lifts``)."""
    for i in range(held.shape[0]):
        held[i], roll[i], swing[i], lifts[i] = False, 0.0, 0.0, -np.inf
    if not verbs[23][v]:
        return
    opens, cols, cyclic = _part(verbs[19], verbs[20], v), _part(verbs[21], verbs[22], v), verbs[5][v]
    times = _columns(caches, slot, v, 4)[c]
    t = g - math.floor(g) if cyclic else min(max(g, 0.0), 1.0)
    for k in range(opens.shape[0]):
        held[cols[k]], roll[cols[k]], swing[cols[k]] = hold_mode(cyclic, t, opens[k], times[3 * k : 3 * k + 3])
    if not cyclic:  # a one-shot verb's swings have no next landing
        return
    table, dims = _part(verbs[24], verbs[25], v), verbs[26]
    ne, ns, nl = dims[v, 0], dims[v, 1], dims[v, 2]
    w = _columns(caches, slot, v, 0)[c]
    lap = math.floor(g)
    x = (g - lap) * (ns - 1)
    k = min(int(math.floor(x)), ns - 2)
    f = x - k
    row = int(min(max(lap, -1.0), 1.0)) + 1  # the cycle before, this one, the one after
    for i in range(nl):
        acc, lo, hi = 0.0, np.inf, -np.inf
        for e in range(ne):
            at = ((row * ne + e) * ns + k) * nl + i
            a = table[at] * (1.0 - f) + table[at + nl] * f
            acc += w[e] * a
            lo, hi = min(lo, a), max(hi, a)
        if not math.isnan(acc):
            lifts[cols[i]] = min(max(acc, lo), hi)


@njit(cache=True, inline="always")
def _carry_limit(c, verbs, caches, state, k_):  # pragma: no cover - compiled
    """``player.carry_limits`` of creature ``c``: the larger of its verbs' own fastest root accelerations at its
    adverbs, the verb playing's and the one being entered's. Each is kept in the carry cache (``clocks._carry``),
    NaN since the adverbs last moved until a frame needs it: then worked out here and kept (``Verb.carry_limit``):
    its examples' root velocities blended with its weights, their change over a frame's step of its clock with the
    heading's turn meanwhile, at their fastest, at least ``SETTLING``, at most the examples' fastest."""
    out = 0.0
    for slot in range(2):
        v = state[0][c] if slot == 0 else state[2][c]
        if v < 0:
            continue
        kept = _columns(caches, slot, v, 5)
        if math.isnan(kept[c, 0]):
            acc = _part(verbs[27], verbs[28], v)
            hi = -np.inf
            for e in range(acc.shape[0]):
                hi = max(hi, acc[e])
            kept[c, 0] = min(max(_fastest(c, v, slot, verbs, caches, k_[_FRAME]), k_[_SETTLING]), hi)
        out = max(out, kept[c, 0])
    return out


@njit(cache=True, inline="always")
def _velocity(samples, w, n_e, n_s, s):  # pragma: no cover - compiled
    """The root velocities ``(vx, vz, turn)`` at sample ``s`` of a verb's ``Verb.root_velocity_samples`` (flat) blended
    with weights ``w``."""
    vx, vz, turn = 0.0, 0.0, 0.0
    for e in range(n_e):
        k = 3 * (e * n_s + s)
        vx += w[e] * samples[k]
        vz += w[e] * samples[k + 1]
        turn += w[e] * samples[k + 2]
    return vx, vz, turn


@njit(cache=True, _nrt=False)
def _fastest(c, v, slot, verbs, caches, frame):  # pragma: no cover - compiled
    """``tables._fastest`` of creature ``c`` in verb ``v`` (slot): its root velocities' fastest change over ``frame``
    seconds of its clock (the velocities there linear between the samples' clock times), the later turned by the
    heading's change meanwhile. Worked out when its adverbs move (not inlined)."""
    samples = _part(verbs[29], verbs[30], v)
    w = _columns(caches, slot, v, 0)[c]
    n_e = _part(verbs[27], verbs[28], v).shape[0]
    n_s = samples.shape[0] // (3 * n_e)
    last = n_s - 1
    end = _clock_of(1.0, v, slot, c, verbs, caches)
    j, t0, t1 = 0, _clock_of(0.0, v, slot, c, verbs, caches), _clock_of(1.0 / last, v, slot, c, verbs, caches)
    most = 0.0
    for s in range(n_s):
        later = _clock_of(s / last, v, slot, c, verbs, caches) + frame
        if later > end:
            break
        while j < last - 1 and t1 <= later:  # (np.interp's interval: t_j <= later < t_j+1, the last closed)
            j += 1
            t0, t1 = t1, _clock_of((j + 1) / last, v, slot, c, verbs, caches)
        ax, az, at = _velocity(samples, w, n_e, n_s, j)
        bx, bz, bt = _velocity(samples, w, n_e, n_s, j + 1)
        u = (later - t0) / (t1 - t0)
        vx, vz, turn = ax + u * (bx - ax), az + u * (bz - az), at + u * (bt - at)
        nx, nz, nt = _velocity(samples, w, n_e, n_s, s)
        angle = 0.5 * (nt + turn) * frame
        co, si = math.cos(angle), math.sin(angle)
        most = max(most, math.hypot(vx * co + vz * si - nx, vz * co - vx * si - nz))
    return most / frame


@njit(cache=True, _nrt=False)
def _creature(c, dt, flags, turns, hbox, buf, hb):  # pragma: no cover
    """``player._step`` for creature ``c``: its pose (not yet planted) into the new pose buffers' rows (:func:`_buffers`
    by ``turns``), its state moved on; ``buf``, ``hb``: the working arrays (:func:`_working`)."""
    verbs, transitions, skeleton, caches, state, _, outputs, k_ = _held(hbox)
    buffers, _ = _buffers(hbox, turns)
    scratch = _working(hbox, buf, hb)
    first, has_shown, has_before, has_held_before = flags
    verb, g, into, g_into, active, beta = state[:6]
    inertial, rebase = state[9], state[10]
    offset_rot, offset_rot_vel, offset_trans, offset_trans_vel = state[11], state[12], state[13], state[14]
    offset_root, offset_since, offset_halflife, moving, root, held_before = state[15:21]
    rot, trans, vel_out, shown_rot, shown_trans, before_rot, before_trans, shown_vel = buffers
    held, roll, swing, kinds, _, _, lifts, eased = outputs  # (events and g_settle: _advance's)
    parents, feet, above_inv, body, arms = skeleton[:5]
    d_a, d_b, e_a, e_b, vel, vel0, r1, r2, blend = scratch[:9]
    rot_b, trans_b, rot0, trans0, hb, rb, sb, wts = scratch[9:17]
    fk_now_pos, fk_now_rot, fk_was_pos, fk_was_rot, xb, rot_b0, trans_b0 = scratch[17:]
    if first:  # the first step without a first frame: the velocities where the creature starts
        _base(c, g[c], g_into[c], hbox, d_a, d_b, vel, blend)
        for a in range(3):
            moving[c, a] = vel[a]
    _advance(c, dt, hbox, buf, hb)
    alpha = _base(c, g[c], g_into[c], hbox, d_a, d_b, vel, blend)
    reb = rebase[c] and has_shown
    rebase[c] = False
    x0, z0, h0 = root[c, 0], root[c, 1], root[c, 2]
    alpha0 = 0.0
    if reb:  # carry on from what was shown: the verbs' times a frame ago (player._back), sampled there
        gb = g_into[c]
        rate_a = 1.0
        if active[c] >= 0:
            rate_a, rate_b = _rates(c, verbs, caches, state)
            gb = _generic_of(_clock_of(g_into[c], into[c], 1, c, verbs, caches) - dt * rate_b, into[c], 1, c, verbs, caches)
        ga = _generic_of(_clock_of(g[c], verb[c], 0, c, verbs, caches) - dt * rate_a, verb[c], 0, c, verbs, caches)
        alpha0 = _base(c, ga, gb, hbox, e_a, e_b, vel0, blend)
        for a in range(3):
            offset_root[c, a] = moving[c, a] - vel0[a]
    offset_since[c] += dt
    if reb:
        offset_since[c] = dt  # the offset was taken a frame ago, at what was shown then
    live = offset_since[c] < 12.0 * offset_halflife[c]
    if live:
        for a in range(3):
            vel[a] += spring(offset_root[c, a], 0.0, offset_since[c], offset_halflife[c], k_[_LN2])
    # The root moves at the velocities of the step's start (a frame's velocity is its step to the next).
    x1, z1, h1 = advance_root_row(x0, z0, h0, moving[c, 0], moving[c, 1], moving[c, 2], dt)
    step_speed = math.hypot(moving[c, 0], moving[c, 1])  # ... and so does a body its feet carry (player._step)
    for a in range(3):
        moving[c, a] = vel[a]
    # In a cosine blend the body goes at the speed of the blend of the verbs' own velocities (player._speeds), and
    # carries that speed into the next step (player._at_blend_speed).
    cosine = active[c] >= 0 and not inertial[c] and transitions[3][active[c]]
    blend_speed = 0.0
    if cosine:
        blend_speed = math.hypot(alpha * d_a[0] + (1.0 - alpha) * d_b[0], alpha * d_a[1] + (1.0 - alpha) * d_b[1])
        m = math.hypot(moving[c, 0], moving[c, 1])
        if m > 1e-12:
            k = blend_speed / m
            moving[c, 0] *= k
            moving[c, 1] *= k
    _decode(c, x1, z1, h1, alpha, verbs, state, d_a, d_b, rot[c], trans[c], rot_b, trans_b)
    if reb:
        # The pose a frame ago, at the root then; the offset is what was shown less it.
        _decode(c, x0, z0, h0, alpha0, verbs, state, e_a, e_b, rot0, trans0, rot_b0, trans_b0)
        n_j = rot0.shape[0]
        for j in range(n_j):
            _relative_into(shown_rot[c, j], rot0[j], offset_rot[c, j])
            for a in range(3):
                offset_trans[c, j, a] = shown_trans[c, j, a] - trans0[j, a]
                offset_rot_vel[c, j, a] = 0.0
                offset_trans_vel[c, j, a] = 0.0
        if has_before:
            for j in range(n_j):
                _relative_into(shown_rot[c, j], before_rot[c, j], r1)
                _relative_into(rot[c, j], rot0[j], r2)
                for a in range(3):
                    offset_rot_vel[c, j, a] = (r1[a] - r2[a]) / dt
                    offset_trans_vel[c, j, a] = ((shown_trans[c, j, a] - before_trans[c, j, a])
                                                 - (trans[c, j, a] - trans0[j, a])) / dt  # fmt: skip
            # The root's own travel is the root's (offset_root): the body root's offset velocity keeps how fast the
            # body moved off its root as shown, less as the verbs move it (player._body_off_root).
            sx, sz, _ = advance_root_row(0.0, 0.0, h0 - shown_vel[c, 2] * dt, shown_vel[c, 0], shown_vel[c, 1],
                                         shown_vel[c, 2], dt)  # fmt: skip
            dx, dz = sx / dt - (x1 - x0) / dt, sz / dt - (z1 - z0) / dt
            tx, _, tz = _rotate(above_inv[0], above_inv[1], above_inv[2], above_inv[3], dx, 0.0, dz)
            offset_trans_vel[c, body, 0] -= tx
            offset_trans_vel[c, body, 2] -= tz
    if live:
        decay_row(offset_since[c], offset_halflife[c], offset_rot[c], offset_rot_vel[c], offset_trans[c],
                  offset_trans_vel[c], rot[c], trans[c], k_[_LN2])  # fmt: skip
    # The arms (a start: the upper body) carried past a short blend into a cycle (player._arms): their offset taken
    # where asked, ended where the whole pose took one, and shown while it lasts (rot_b: B's rotations now).
    arms_since, arms_take = state[23], state[25]
    arms_since[c] += dt
    if reb:
        arms_since[c] = np.inf
    if arms_take[c]:
        arms_take[c] = False
        # (a blend turned back and over within the frame: taken again against A, alone; with no offset alive, none)
        if has_shown and arms.shape[0] > 0 and (active[c] >= 0 or arms_since[c] < state[26][c]):
            _arms_take(c, dt, has_before, x0, z0, h0, hbox, arms, shown_rot, before_rot, e_b,
                       rot_b if active[c] >= 0 else rot[c], rot0, trans0, r1, r2, blend)  # fmt: skip
    if arms_since[c] < state[26][c]:
        n = arms.shape[0] if state[28][c] else skeleton[8]  # the whole upper body, or the arms alone
        if active[c] >= 0 and active[c] == state[24][c]:  # in the blend that took it: the arms play B
            for i in range(n):
                for a in range(4):
                    rot[c, arms[i], a] = rot_b[arms[i], a]
        _arms_show(arms_since[c], state[26][c], state[21][c], state[22][c], arms, n, rot[c])
    # Hold phases: A's, B's, or in a cosine blend A's while it has the weight, then both's (player.hold_phases).
    is_moving = active[c] >= 0
    inert = is_moving and inertial[c]
    if not inert:
        _phases(verb[c], 0, c, g[c], verbs, caches, held[c], roll[c], swing[c], lifts[c])
    if is_moving:
        _phases(into[c], 1, c, g_into[c], verbs, caches, hb, rb, sb, xb)
        first = alpha >= 0.5
        for i in range(hb.shape[0]):
            if inert:
                held[c, i], roll[c, i], swing[c, i], lifts[c, i] = hb[i], rb[i], sb[i], xb[i]
            else:
                # The examples' lifts blended as the pose is; none where either verb has none.
                ea = lifts[c, i]
                lifts[c, i] = alpha * ea + (1.0 - alpha) * xb[i] if math.isfinite(ea) and math.isfinite(xb[i]) else -np.inf
                ha, ra, sa = held[c, i], roll[c, i], swing[c, i]
                taken = hb[i] and not ha and sa < k_[_LANDS]  # B takes it from A's swing as A begins to land it
                held[c, i] = (ha and (hb[i] or first)) or taken
                if taken:  # held from A's least lift (player.hold_phases)
                    lifts[c, i] = max(lifts[c, i], k_[_SWING_LIFT] * sa)
                if ha and (hb[i] or first):  # the verbs' rolls blended as the pose is (player.hold_phases)
                    roll[c, i] = alpha * ra + (1.0 - alpha) * rb[i]
                elif not first:
                    roll[c, i] = rb[i]
                if ha and not hb[i]:  # the lift of the verb swinging it (B's; A's where only B holds it)
                    swing[c, i] = sb[i]
                elif ha and hb[i]:  # both hold it: the lift of the one rolling it off
                    swing[c, i] = max(sa, sb[i])
                elif not ha and not hb[i]:
                    swing[c, i] = min(sa, sb[i])
    # The examples' lifts' share under a decaying offset: as much as it has decayed (player.step).
    eased[c] = 1.0 - spring(1.0, 0.0, offset_since[c], offset_halflife[c], k_[_LN2]) if live else 1.0
    kinds[c, 0] = (not is_moving or not transitions[3][active[c]]) and not live  # one verb (player._step)
    kinds[c, 1] = not verbs[5][into[c] if is_moving else verb[c]]  # standing, or coming to stand (player._standing)
    kinds[c, 2] = kinds[c, 1] and verbs[5][verb[c]]  # from a cycle: a stop (planted.plant)
    # The body carried by the held feet's slip in a blend (player._keep_feet).
    root[c, 0], root[c, 1], root[c, 2] = x1, z1, h1
    if has_shown and has_held_before:
        lagging = state[27]
        if live or cosine or lagging[c]:
            alone = not (live or cosine)  # catching up with its verb's velocity, the carry limit's rate
            for i in range(feet.shape[0]):
                wts[i] = 0.0 if alone else (1.0 if (held[c, i] and held_before[c, i]) else 0.0) * (1.0 - roll[c, i])
            # At the speed of the step's start: in a cosine blend the blend of the verbs' own velocities, else at
            # least the root's own (player._step, player._speeds); its velocity changing no faster than its verbs'
            # own (player._keep_feet).
            lo, hi = (0.0 if alone else step_speed), np.inf
            fade = 1.0  # under a decaying offset alone, as much of the slip as is left of the offset (player._keep_feet)
            if cosine:
                hi = step_speed
            elif not alone:
                fade = spring(1.0, 0.0, offset_since[c], offset_halflife[c], k_[_LN2])
            change = _carry_limit(c, verbs, caches, state, k_)
            lagging[c] = keep_feet_row(
                parents, feet, skeleton[6], wts, rot[c : c + 1], trans[c : c + 1], shown_rot[c : c + 1], shown_trans[c : c + 1], body,
                above_inv, root[c], fk_now_pos, fk_now_rot, fk_was_pos, fk_was_rot, x0, z0, h0, shown_vel[c, 0],
                shown_vel[c, 1], shown_vel[c, 2], lo, hi, change, fade, dt,
            )  # fmt: skip
    vel_out[c, 0], vel_out[c, 1], vel_out[c, 2] = root_velocity_row(x0, z0, h0, root[c, 0], root[c, 1], root[c, 2], dt)
    for i in range(feet.shape[0]):
        held_before[c, i] = held[c, i]


@njit(cache=True, _nrt=False)
def _arms_take(c, dt, has_before, x0, z0, h0, hbox, arms, shown_rot, before_rot, e_b, rot_b, rot0,
               trans0, r1, r2, blend):  # pragma: no cover  # fmt: skip
    """``player._arms``'s taking of creature ``c``'s arms' offset (a frame now and then: not inlined), from the pose
    shown and B a frame ago (decoded into ``rot0``) and now (``rot_b``); A's, playing alone, where no blend is under
    way (one turned back and over within the frame)."""
    verbs, _, skeleton, caches, state, _, _, _ = _held(hbox)
    verb, g, into, g_into, active = state[:5]
    arms_rot, arms_vel, arms_since, arms_of = state[21], state[22], state[23], state[24]
    # B (A, alone) a frame ago, by its clock (player._back).
    if active[c] >= 0:
        v, slot, gv = into[c], 1, g_into[c]
        _, rate = _rates(c, verbs, caches, state)
    else:
        v, slot, gv, rate = verb[c], 0, g[c], 1.0
    gb = _generic_of(_clock_of(gv, v, slot, c, verbs, caches) - dt * rate, v, slot, c, verbs, caches)
    _dofs(e_b, v, slot, c, gb, verbs, caches, blend)
    _decode_verb(v, e_b, x0, z0, h0, verbs, rot0, trans0)
    for i in range(arms.shape[0]):
        j = arms[i]
        _relative_into(shown_rot[c, j], rot0[j], arms_rot[c, i])
        for a in range(3):
            arms_vel[c, i, a] = 0.0
        if has_before:
            _relative_into(shown_rot[c, j], before_rot[c, j], r1)
            _relative_into(rot_b[j], rot0[j], r2)
            for a in range(3):
                arms_vel[c, i, a] = (r1[a] - r2[a]) / dt
    arms_since[c] = dt
    arms_of[c] = active[c]
    n = arms.shape[0] if state[28][c] else skeleton[8]  # the whole pose's offset on the joints it shows: handed to it
    for i in range(n):  # (player._arms)
        for a in range(3):
            state[11][c, arms[i], a] = 0.0
            state[12][c, arms[i], a] = 0.0


@njit(cache=True, inline="always")
def _arms_show(t, length, arms_rot, arms_vel, arms, n, rot):  # pragma: no cover - compiled
    """``player._arms``'s offset ``t`` seconds on (of ``length``; ``arms_rot``, ``arms_vel (U, 3)``), before the
    rotations of the first ``n`` carried joints ``arms (U,)`` in ``rot (J, 4)``: ``o(t) = w(t / T) x₀ + v₀ t
    (1 − t / T)³``."""
    u = t / length
    w, tail = 0.5 * math.cos(np.pi * u) + 0.5, t * (1.0 - u) ** 3
    for i in range(n):
        j = arms[i]
        ex, ey, ez, ew = _exp(w * arms_rot[i, 0] + tail * arms_vel[i, 0], w * arms_rot[i, 1] + tail * arms_vel[i, 1],
                              w * arms_rot[i, 2] + tail * arms_vel[i, 2])  # fmt: skip
        q = _mul(ex, ey, ez, ew, rot[j, 0], rot[j, 1], rot[j, 2], rot[j, 3])
        for a in range(4):
            rot[j, a] = q[a]


@njit(cache=True, inline="always")
def _scratch(buf, hb, n_d, n_j, n_l):  # pragma: no cover - compiled
    """One creature's working arrays (see :func:`_creature`), carved from ``buf`` (:func:`_scratch_size` long, kept
    alive by the caller), and ``hb (L,)``, the caller's."""
    d_a, at = carve(buf, 0, (n_d,))
    d_b, at = carve(buf, at, (n_d,))
    e_a, at = carve(buf, at, (n_d,))
    e_b, at = carve(buf, at, (n_d,))
    vel, at = carve(buf, at, (3,))
    vel0, at = carve(buf, at, (3,))
    r1, at = carve(buf, at, (3,))
    r2, at = carve(buf, at, (3,))
    blend, at = carve(buf, at, (4,))
    rot_b, at = carve(buf, at, (n_j, 4))
    trans_b, at = carve(buf, at, (n_j, 3))
    rot0, at = carve(buf, at, (n_j, 4))
    trans0, at = carve(buf, at, (n_j, 3))
    rb, at = carve(buf, at, (n_l,))
    sb, at = carve(buf, at, (n_l,))
    wts, at = carve(buf, at, (n_l,))
    now_pos, at = carve(buf, at, (1, n_j, 3))
    now_rot, at = carve(buf, at, (1, n_j, 4))
    was_pos, at = carve(buf, at, (1, n_j, 3))
    was_rot, at = carve(buf, at, (1, n_j, 4))
    xb, at = carve(buf, at, (n_l,))
    rot_b0, at = carve(buf, at, (n_j, 4))
    trans_b0, at = carve(buf, at, (n_j, 3))
    return (
        d_a, d_b, e_a, e_b, vel, vel0, r1, r2, blend, rot_b, trans_b, rot0, trans0, hb, rb, sb,
        wts, now_pos, now_rot, was_pos, was_rot, xb, rot_b0, trans_b0,
    )  # fmt: skip


@njit(cache=True, inline="always")
def _scratch_size(n_d, n_j, n_l):  # pragma: no cover - compiled
    """How many floats :func:`_scratch` carves."""
    return 4 * n_d + 4 * 3 + 4 + 35 * n_j + 4 * n_l


@njit(cache=True, _nrt=False)
def _chunk(lo, hi, dt, flags, turns, hbox, buf, hb):  # pragma: no cover
    """Creatures ``lo`` to ``hi``: :func:`_creature` for each, their poses copied into the planted pair
    (:func:`_buffers`); ``buf`` (:func:`_scratch_size` long) and ``hb (L,)``: the working arrays, the caller's."""
    state = _held(hbox)[4]
    buffers, planted = _buffers(hbox, turns)
    rot, trans = buffers[0], buffers[1]
    out_rot, out_trans = planted
    n_j = rot.shape[1]
    time = state[8]
    for c in range(lo, hi):
        time[c] += dt  # (player.step: state.time += dt)
        _creature(c, dt, flags, turns, hbox, buf, hb)
        for j in range(n_j):
            for a in range(4):
                out_rot[c, j, a] = rot[c, j, a]
            for a in range(3):
                out_trans[c, j, a] = trans[c, j, a]


@njit(cache=True, nogil=True)
def frame(lo, hi, dt, flags, turns, box):  # pragma: no cover - compiled
    """One frame of creatures ``lo`` to ``hi``, feet not planted: :func:`_chunk`, chunk by chunk. Releases the GIL:
    threads run other ranges of creatures at the same time.

    ``flags = (first, shown, shown before, held before, planter starting)``; ``turns``: which of the three pose
    buffers is new, shown and shown before, and which of the two planted ones is written. ``box``: what does not
    change from frame to frame, ``(verbs, transitions, skeleton, caches, state, head, poses, outputs, k_, chunk, n_d,
    planted)``, held (``_borrow_kernel.hold``). Returns whether every foot target was finite (always, here) and how
    many creatures have an event for Python to settle.
    """
    return _frame(lo, hi, dt, flags, turns, box, None)


@njit(cache=True, nogil=True)
def frame_planted(lo, hi, dt, flags, turns, box, feet):  # pragma: no cover - compiled
    """:func:`frame`, then :func:`_plant` on each chunk's poses; ``feet``: the planter's arrays, held."""
    return _frame(lo, hi, dt, flags, turns, box, feet)


@njit(cache=True)
def _frame(lo, hi, dt, flags, turns, held, feet):  # pragma: no cover - compiled
    # Every array given, borrowed: the views the pass takes of them are not counted (see _borrow_kernel).
    boxed = borrowed_box(held)
    _, _, _, _, state, _, _, outputs, k_, chunk, _, _ = boxed
    _, planted = _buffers(held, turns)
    n_d, n_j, n_l = _sizes(held)
    buf, hb = np.empty(_scratch_size(n_d, n_j, n_l)), np.empty(n_l, dtype=np.bool_)
    finite = True
    for start in range(lo, hi, chunk):
        stop = min(start + chunk, hi)
        _chunk(start, stop, dt, flags[:4], turns, held, buf, hb)
        if feet is not None:
            mix = (state[0], state[2], state[4], state[5], state[9])  # verb, into, active, beta, inertial
            finite = _plant(start, stop, dt, outputs, planted, borrowed_box(feet), flags[4], k_, mix) and finite
    keep(buf)  # _chunk carves it: kept to the last chunk
    keep(hb)
    events = outputs[4]
    n_events = 0
    for c in range(lo, hi):
        if events[c] != 0:
            n_events += 1
    return finite, n_events


@njit(cache=True, inline="always")
def _mix(c, mix):  # pragma: no cover - compiled
    """The verbs a creature shows, A and B (A twice alone), and A's weight: ``player._verbs`` and ``_Base.alpha``."""
    verb, into, active, beta, inertial = mix
    if active[c] < 0:
        return verb[c], verb[c], 1.0
    alpha = 0.0 if inertial[c] else _blend_weight(beta[c])
    return verb[c], into[c], alpha


@njit(cache=True, inline="always")
def _level(levels, c, i, a, b, alpha):  # pragma: no cover - compiled
    """``planted._level`` of one foot: its contact level in verbs ``a`` and ``b`` blended by ``alpha`` (NaN: unknown)."""
    if alpha >= 1.0:
        return levels[c, i, a]
    if alpha <= 0.0:
        return levels[c, i, b]
    return alpha * levels[c, i, a] + (1.0 - alpha) * levels[c, i, b]


@njit(cache=True, _nrt=False)
def _plant(lo, hi, dt, outputs, planted, feet, start, k_, mix):  # pragma: no cover - compiled
    """``planted.plant`` for creatures ``lo`` to ``hi``: the planter's kernel on their poses (in place), then which feet
    to re-place (``GraphFeet``). ``start``: the planter's first frame; ``dt``: its step, every creature's; ``mix``:
    the state's verb, into, active, beta and inertial (the verbs shown, for each foot's contact level). ``feet``: the
    planter's held arrays, borrowed (:func:`_frame` takes them out of their ``Held``: not without counting)."""
    held, roll, swing, kinds, lifts, eased = outputs[0], outputs[1], outputs[2], outputs[3], outputs[6], outputs[7]
    (parents, generic, inside, dts, times, cyclic, verb_floor, tips, root, legs, constants, floor, st, chain,
     ik_params, scratch, drop, residual, replanting, levels, hover0, level0, pending) = feet  # fmt: skip
    rot, trans = planted
    n_l = held.shape[1]
    mode, offset, offset_vel, since, settle, hover = st[0], st[4], st[5], st[6], st[11], st[12]
    ln2 = k_[_LN2]
    for c in range(lo, hi):
        dts[c] = dt
        a, b, alpha = _mix(c, mix)
        for i in range(n_l):  # a free foot's contact level moved with the verbs' (planted._rebase_hover)
            if mode[c, i] == FREE:
                moved = _level(levels, c, i, a, b, alpha) - level0[c, i]
                if math.isfinite(moved):
                    hover[c, i] = hover0[c, i] + moved
        for i in range(n_l):
            inside[c, i] = held[c, i] and not replanting[c, i]
            if replanting[c, i]:  # a foot re-placed steps: it swings at the least lift, not along the floor
                swinging = 0.0 if held[c, i] else swing[c, i]  # the lift of a verb swinging it itself
                swing[c, i] = 0.0  # planted._step_lift: none while held, up from its release, down near the verb's
                if mode[c, i] == FREE:
                    across = 0.0
                    if not settle[c, i]:
                        for a in (0, 2):
                            x = spring(offset[c, i, a], offset_vel[c, i, a], since[c, i, a], k_[_SWING], ln2)
                            across += x * x
                    land = smoothstep((math.sqrt(across) - k_[_REPLANTED]) / (k_[_LAND] - k_[_REPLANTED]))
                    swing[c, i] = smoothstep(since[c, i, 1] / k_[_RISE]) * max(land, swinging)
    s = slice(lo, hi)
    sliced = (
        st[0][s], st[1][s], st[2][s], st[3][s], st[4][s], st[5][s], st[6][s], st[7][s], st[8][s], st[9][s], st[10][s],
        st[11][s], st[12][s], st[13][s], st[14][s], st[15][s], st[16][s], st[17][s],
    )  # fmt: skip
    out = (scratch[0][s], scratch[1][s], scratch[2][s], scratch[3][s], drop[s], residual[s])
    finite = plant_step(
        parents, rot[s], trans[s], generic[s], inside[s], roll[s], swing[s], lifts[s], eased[s], held[s], True, dts[s],
        start, times[s], cyclic, verb_floor, tips, root, legs, constants, floor, sliced, chain, ik_params, out,
    )  # fmt: skip
    turn, target, spent, prev_free = st[1], st[2], st[7], st[14]
    for c in range(lo, hi):
        a, b, alpha = _mix(c, mix)
        one = a if (alpha >= 1.0 or a == b) else (b if alpha <= 0.0 else -1)
        for i in range(n_l):  # the level of a foot let go this frame (planted._take_levels)
            if mode[c, i] == FREE and since[c, i, 1] == 0.0:
                if one >= 0:
                    levels[c, i, one] = hover[c, i]
                hover0[c, i] = hover[c, i]
                level0[c, i] = _level(levels, c, i, a, b, alpha)
        for i in range(n_l):
            if spent[c, i] and mode[c, i] == FREE and held[c, i] and roll[c, i] == 0.0:  # let go, held flat
                replanting[c, i] = True
            if replanting[c, i] and mode[c, i] == FREE and since[c, i, 1] == 0.0:
                for a in (0, 2):  # let go this frame: it travels once lifted, held where it is until then
                    offset_vel[c, i, a] = 0.0
                    since[c, i, a] = -k_[_DELAY]
            if replanting[c, i]:
                # Settled once the free rule's offset (FootPlanter._offset) has decayed to REPLANTED.
                norm = 0.0
                if not settle[c, i]:
                    sq = 0.0
                    for a in range(3):
                        h = k_[_LIFT] if a == 1 else k_[_SWING]
                        x = spring(offset[c, i, a], offset_vel[c, i, a], since[c, i, a], h, ln2)
                        sq += x * x
                    norm = math.sqrt(sq)
                if mode[c, i] == FREE and norm < k_[_REPLANTED] and since[c, i, 0] > 0:
                    replanting[c, i] = False
        # Held flat too far from where the verbs have it (planted.plant; standing: planted._standing_far).
        standing, shifted, further = kinds[c, 1], False, 0
        if standing:  # the body off its feet: every foot held flat, their mean offset over SHIFTED; the further one
            flat_all, mx, mz, most = True, 0.0, 0.0, -1.0
            for i in range(n_l):  # (standing, flat as the verbs hold it: planted.plant)
                flat_all = flat_all and mode[c, i] == BALL and roll[c, i] == 0.0
                mx += prev_free[c, i, 0] - target[c, i, 0]
                mz += prev_free[c, i, 2] - target[c, i, 2]
                gap = math.hypot(prev_free[c, i, 0] - target[c, i, 0], prev_free[c, i, 2] - target[c, i, 2])
                if gap > most:
                    further, most = i, gap
            shifted = flat_all and math.hypot(mx / n_l, mz / n_l) > k_[_SHIFTED]
        far = k_[_REPLANT] if kinds[c, 0] else k_[_LEFT_BEHIND]
        if standing:  # (a stop: STOPPING)
            far = k_[_STOPPING] if kinds[c, 2] else k_[_STANDING]
        down = 0  # standing, a foot steps only while every other is down (planted._others_down)
        for i in range(n_l):
            if mode[c, i] != FREE and not replanting[c, i]:
                down += 1
        for i in range(n_l):
            gap = math.hypot(prev_free[c, i, 0] - target[c, i, 0], prev_free[c, i, 2] - target[c, i, 2])
            # A stop's foot STOPPING off, held down by the planter (BALL), steps though the walk still rolls it a
            # little, once the other is down, in the stop or after it while standing that far off (planted.plant).
            wants = mode[c, i] == BALL and gap > k_[_STOPPING]
            pending[c, i] = wants if kinds[c, 2] else (pending[c, i] and wants and standing)
            flat = mode[c, i] == BALL and (roll[c, i] == 0.0 if standing else turn[c, i] == 0.0)
            waited = standing and pending[c, i] and (kinds[c, 2] or roll[c, i] == 0.0)  # past the stop: held flat
            if (flat and (gap > far or (shifted and i == further))) or waited:
                if not standing or down - (not replanting[c, i]) == n_l - 1:
                    replanting[c, i] = True
            if replanting[c, i]:
                pending[c, i] = False
    return finite


@njit(cache=True, nogil=True)
def same(a, b):  # pragma: no cover - compiled
    """Whether two 2-D float arrays hold the same values (a NaN is never the same): ``np.array_equal`` of the
    creatures' adverb points, checked every frame, without NumPy's 2 µs of Python."""
    if a.shape != b.shape:
        return False
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            if a[i, j] != b[i, j]:
                return False
    return True
