"""The discrete decisions of a verb graph (§5), taken at the times they happen: a command queues the path with the
fewest transitions to the verb asked for (:func:`command`); a transition starts when the verb reaches its region
(:func:`_start`) and ends when ``β`` reaches 1 (:func:`_finish`); a command during an interruptible transition
turns the blend back (:func:`_reverse`) or lets the verb being entered play on alone from the pose shown
(:func:`_interrupt`), but for a stop (a cycle into a one-shot), which ends first; the latency of a command is
noted when its verb plays alone (:func:`_arrived`).
"""

from __future__ import annotations


import numpy as np

from .structure import CommandRefused
from .clocks import _sampling, clock_of, duration, paced_length
from .state import (
    INERTIAL_HALFLIFE, INTERRUPT_HALFLIFE, MIN_DURATION, MIN_LOOP, ARMS_BLEND, _LATE, GraphState, _settle_queue, sync_head,
)  # fmt: skip


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
    if state.active[c] >= 0 and target != state.into[c] and graph.transitions[state.active[c]].interruptible and not (
        _loop_plays_on(state, c, path)
    ):
        if target == state.verb[c] and graph.verbs[target].cyclic and not state.inertial[c]:
            _reverse(state, c)  # back to the cycle it was leaving, by the same blend
            state.queue[c] = []
            return []
        # A stop (a cycle blending into a one-shot) runs on: the path goes on from the verb it enters, once its feet
        # are down. Cut short, the body went on at the cycle's speed (decaying) under the one-shot's pose.
        stopping = graph.verbs[state.verb[c]].cyclic and not graph.verbs[state.into[c]].cyclic and not state.inertial[c]
        if not stopping:
            _interrupt(state, c)
            state.queue[c] = list(path)
            first = graph.transitions[path[0]]
            if not graph.verbs[first.source].cyclic and state.g[c] >= first.source_region[0]:
                # The way on from the verb being entered is open already: take it at once, from the pose shown. Between
                # standing verbs it blends as it would have (paced: clocks.paced_length), the interrupted blend's
                # difference decaying under it: entered at once, a bow's first frame (its legs at 30-50°/s) was
                # carried on in the offset's velocity, the legs turning against the bow at up to 43°/s.
                _start(state, c, 0.0, inertial=not graph.paced_transitions[path[0]])
                return list(path)
    state.queue[c] = list(path)
    if state.active[c] < 0:
        _settle_queue(state, c)
        if target == state.verb[c]:
            _arrived(state, c)
    return list(state.queue[c])


def _loop_plays_on(state: GraphState, c: int, path: list[int]) -> bool:
    """Whether creature ``c``, in a cycle's loop into itself, plays the loop on rather than cut it short for ``path``:
    where the cycle's next cycle (the loop's B) is not yet in the path's first region, cut short it only began the loop
    again (late, from where it was cut: a CMU run's loop then took 0.07 s, its blend weight going 0.40, 0.56, 0.01) and
    went on from there no sooner."""
    graph = state.graph
    t = graph.transitions[state.active[c]]
    if t.source != t.target or not graph.verbs[t.source].cyclic:
        return False
    g = float(state.g_into[c]) % 1.0  # where the loop's B is in its cycle
    start, end = graph.transitions[path[0]].source_region
    return not start <= g < end


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
    if state.arms_of[c] == state.active[c] and state.arms_since[c] < state.arms_length[c]:
        state.arms_take[c] = True  # the arms carried on from the pose shown, onto the verb now entered


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
    whole = False  # B's region played whole, at no more than its own speed
    if g > sa + _LATE:  # the region has begun already (a one-shot verb past it, or a loop begun late)
        if not a.cyclic:  # what is left of A's region blends into the whole of B's, from where B's begins
            sa, ea, whole = g, max(ea, g), True
        elif g < ea:
            sb += (g - sa) / (ea - sa) * (eb - sb)
            sa = g
        else:
            sa = ea = g
    if b.cyclic and eb >= 1.0:  # B plays the end of its previous cycle
        sb, eb = sb - 1.0, eb - 1.0
    row = np.array([c])
    caches = _sampling(state, t.source, 0), _sampling(state, t.target, 1)
    keys_a, keys_b = caches[0].keytimes[row], caches[1].keytimes[row]
    length = float(duration((sa, ea), (sb, eb), keys_a, keys_b, a.generic_keytimes, b.generic_keytimes)[0])
    cut = inertial or t.blend == "inertial"  # B at once: A is not played through its region
    if whole:  # not shorter than B's region: B's clock never runs faster than its own
        clocks_b = clock_of(np.array([[sb, eb]]), keys_b, b.generic_keytimes)[0]
        length = max(length, float(clocks_b[1] - clocks_b[0]))
        if not cut:
            # As long as the blend begun where A's region begins: a command late in a one-shot's region does not
            # shorten it (a stand's last tenth into a gesture's lead-in took 0.15 s, the trunk at 2x its verbs' own);
            # A's clock runs slower through what is left of its region instead.
            whole_a = duration(t.source_region, (sb, eb), keys_a, keys_b, a.generic_keytimes, b.generic_keytimes)[0]
            length = max(length, float(whole_a))
    if not cut and graph.paced_transitions[k]:  # long enough for no part to turn too fast by the blend alone
        length = max(length, paced_length(state, c, k, (sa, ea, sb, eb), caches))
    state.active[c], state.into[c] = k, t.target
    state.regions[c] = (sa, ea, sb, eb)
    state.length[c] = max(length, MIN_LOOP if t.source == t.target else MIN_DURATION)
    state.beta[c] = min(late / state.length[c], 1.0)
    state.g_into[c] = sb
    state.inertial[c] = cut
    if state.inertial[c]:  # B at once, the pose shown decaying onto it
        state.rebase[c] = True
        state.offset_halflife[c] = max(INERTIAL_HALFLIFE * state.length[c], INTERRUPT_HALFLIFE if inertial else 0.0)
    elif (kind := graph.carries_arms[k]) == 2 or (kind in (1, 3) and state.length[c] < ARMS_BLEND):
        # The arms (a start: the upper body) play B at once, the pose shown's difference carried on (player._arms),
        # past the blend (a stop: over it); the whole upper body again while a start's offset of it is alive (were it
        # dropped, the trunk would snap back to the blend's in a frame).
        alive = state.arms_upper[c] and state.arms_since[c] < state.arms_length[c]
        state.arms_upper[c] = kind == 3 or alive
        state.arms_take[c], state.arms_length[c] = True, state.length[c] if kind == 2 else ARMS_BLEND


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
