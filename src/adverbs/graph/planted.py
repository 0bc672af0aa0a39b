"""A verb graph's planted feet: the foot planter of :mod:`adverbs.feet` fed each frame's hold phases, and the feet
it re-places when the verbs have them somewhere else.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import AdverbsError
from ..kinematics.floor import Floor
from ..feet.planter import BALL, FREE, FootPlanter, _smoothstep, effector_joints
from .structure import Graph
from .player import Frame
from .state import GraphState


REPLANT = 0.12  # metres: a held foot this far (across the floor) from where the verb playing has it is re-placed
#   (a walk's own stance foot slides from where it landed: held where it landed, it is 2-7 cm from the walk's at
#   most adverb points by toe-off, up to 15 cm in sharp turns; at 6 cm most walks re-placed a stance foot mid-stance,
#   lifting it 3 cm and gliding it on while the verb had it down)
REPLANTED = 0.01  # metres: ... until the released foot is this near the verb's again
LEFT_BEHIND = 0.12  # metres: in a blend, a held foot this far from where the verbs have it is re-placed
STANDING = 0.15  # metres: ... and where the creature stands or comes to stand (the verb entered is a one-shot) ...
STOPPING = 0.09  # metres: ... but where it comes to stand from a cycle (a stop), so the stand starts on its own stance
SHIFTED = 0.08  # metres: ... or, standing, when its held feet are this far on average (the body off them): the further
STEP_RISE = 0.06  # seconds: a re-placed foot's lift rises over this long from its release ...
STEP_DELAY = 0.04  # seconds: ... and it travels only after this long (lifted first) ...
STEP_LAND = 0.03  # metres: ... and comes back down as it comes from this to REPLANTED of where the verb has it


@dataclass
class GraphFeet:
    """A graph's foot planter for C creatures (:func:`planter`), and which feet it is moving to a new place.

    A foot held across verbs that stand it in different places (a stand with the feet apart, then a walk), or
    that a blend carries the body away from (a run slowing into a walk at the blend of the two speeds; a loop
    moving the legs by its cycle's seam), ends up held where the verbs do not have it, and the leg stretches or the
    hips drop. Such a foot, flat on the floor and ``REPLANT`` from where the verbs have it, is let go (the planter's inertialized release: it lifts, then
    travels, at least the planter's least swing lift over the floor, so it steps rather than glides) and held
    again once it has come within ``REPLANTED`` of where the verb puts it.
    """

    planter: FootPlanter
    replanting: np.ndarray
    levels: np.ndarray  # (C, L, V): each foot's contact level in each verb, as the planter last took it there
    #   (before it has: the verb's own at the creature's adverbs, Verb.contact_levels; see know_levels)
    hover0: np.ndarray  # (C, L): a free foot's contact level (FootPlanter.hover) when it was let go ...
    level0: np.ndarray  # (C, L): ... and the levels of the verbs shown then (NaN: not known)
    known: np.ndarray  # (C, V): which verbs' levels know_levels has looked for
    leveled: np.ndarray  # (V,): which verbs have levels of their own (a cycle that holds feet: Verb.contact_levels)
    targets: np.ndarray  # (T,): each transition's target verb
    cyclic: np.ndarray  # (V,): which verbs are cycles (a blend from one into a one-shot is a stop)
    pending: np.ndarray  # (C, L): feet a stop would have re-placed had the other been down (stepping after it)
    looked: tuple = ()  # (state, GraphState.head_version) when know_levels last looked

    @property
    def mode(self) -> np.ndarray:
        """What each foot is doing as shown (``FootPlanter.shown_mode``), as reports record it."""
        return self.planter.shown_mode

    @property
    def turn(self) -> np.ndarray:
        """How far each foot is off flat (``FootPlanter.rolled``), as reports record it."""
        return self.planter.rolled

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
    shape = (creatures, len(tips))
    return GraphFeet(
        FootPlanter(holding[0], creatures, floor), np.zeros(shape, dtype=bool), np.full((*shape, len(graph.verbs)), np.nan),
        np.zeros(shape), np.full(shape, np.nan), np.zeros((creatures, len(graph.verbs)), dtype=bool),
        np.array([bool(v.cyclic and v.holds) for v in graph.verbs]),
        np.array([t.target for t in graph.transitions], dtype=np.int64), graph.cyclic, np.zeros(shape, dtype=bool),
    )  # fmt: skip


def know_levels(feet: GraphFeet, state: GraphState, rows: slice = slice(None)) -> None:
    """Each foot's contact level in the verbs each creature plays, enters and enters next (its queue's first
    transition's target) where the planter has taken none yet: the verb's own at the creature's adverbs
    (:meth:`Verb.contact_levels`), once for each creature and verb. Called before each frame, by every path alike;
    ``rows``: the state's creatures ``feet`` plants (all of them, or one of a dataset's, each with its own planter).
    Those verbs change only with a queue's first transition (a transition starting moves it on, a command replaces
    it; ``GraphState.head_version``), so it looks again only when that has moved: it costs tens of µs of NumPy.

    The planter takes a foot's level in a verb as it lets the foot go there (:func:`_take_levels`); a foot's first
    stance in a verb had none, so a free foot's level did not move into the verb's: the first run after a CMU walk
    at 2.8 m/s landed its first foot with the walk's level (−5 mm where the run's own is −28), 23 mm low, and its toe
    ran 116 mm along the floor (the run's own 84)."""
    again = bool(feet.looked) and feet.looked[0] is state
    if again and feet.looked[1] == state.head_version:
        return
    since = feet.looked[1] if again and state.head_stamp is not None else None
    feet.looked = (state, state.head_version)
    graph = state.graph
    head = state.head if state.head is not None else np.array([q[0] if q else -1 for q in state.queue], dtype=np.int64)
    verb, into, active, points, head = state.verb[rows], state.into[rows], state.active[rows], state.points[rows], head[rows]
    # Only the creatures whose queue's first transition was noted since the last look (sync_head): a crowd's frame
    # notes a few hundred of 10,000, and looking at all of them cost 1 ms a frame.
    moved = np.arange(len(verb)) if since is None else np.flatnonzero(state.head_stamp[rows] > since)
    if not len(moved):
        return
    verb, into, active, points, head = verb[moved], into[moved], active[moved], points[moved], head[moved]
    verbs = np.stack([verb, np.where(active >= 0, into, verb), np.where(head >= 0, feet.targets[head], verb)], axis=1)
    need = feet.leveled[verbs] & ~feet.known[moved[:, None], verbs]
    if not need.any():
        return
    for v in np.unique(verbs[need]).tolist():
        i = np.flatnonzero((need & (verbs == v)).any(axis=1))
        c = moved[i]
        cols = graph.hold_layout[v][1]
        worked = graph.verbs[v].contact_levels(graph.verb_points(v, points[i]))  # (n, L_v)
        kept = feet.levels[c[:, None], cols[None, :], v]
        feet.levels[c[:, None], cols[None, :], v] = np.where(np.isnan(kept), worked, kept)  # what it took stays
        feet.known[c, v] = True


def _step_lift(p: FootPlanter, swinging: np.ndarray) -> np.ndarray:
    """How much of the least swing lift a re-placed foot has ``(C, L)``: a step, not a hop. None while it is still
    held (it is let go this frame); rising by smoothstep over ``STEP_RISE`` from its release (its height's time,
    which does not wait); and coming back down as its offset from where the verb has it (the planter's, as of the
    last frame) falls from ``STEP_LAND`` to ``REPLANTED``, where it is held again. Lifted at once and dropped at
    once, a standing foot's knee turned 470-630 deg/s in a reach whose own legs are still.

    It comes down no lower than ``swinging (C, L)``, the lift of a verb that swings the foot itself (0 where the
    verbs hold it): a walk's foot re-placed as it rolled off, in a stop, was brought down onto the walk's swing
    where the blend with the stand drew it along the floor, and its toe skidded 17 cm."""
    off = p._offset()
    rise = _smoothstep(p.since[..., 1] / STEP_RISE)
    land = _smoothstep((np.hypot(off[..., 0], off[..., 2]) - REPLANTED) / (STEP_LAND - REPLANTED))
    return np.where(p.mode == FREE, rise * np.maximum(land, swinging), 0.0)


def plant(feet: GraphFeet, frame: Frame, dt: float, alone: np.ndarray, standing: np.ndarray | None = None):
    """The frame's feet planted: rotations ``(C, J, 4)``, translations ``(C, J, 3)`` and the IK result; feet held
    too far from where the verbs have them are re-placed (see :class:`GraphFeet`): ``REPLANT`` away where
    ``alone (C,)`` says a creature plays one verb (alone or in its own loop; no decaying offset), ``LEFT_BEHIND`` in
    a blend of two verbs, and ``STANDING`` where ``standing (C,)`` (``GraphState.standing``) says a creature stands
    or comes to stand: the verb it plays alone, or the one it is entering, is a one-shot (a stand, a gesture, a stop;
    ``None``: none does).

    Standing verbs stand their feet where their takes did, up to 12 cm apart from one another (the Bandai guide
    ends with the left toe 11 cm behind where the stand has it), and a stop lands its feet where the walk had them.
    Re-placed at 6 or 12 cm, a stand after a gesture or a stop stepped, its knee at 200-320 deg/s where the stand's
    own turns at 10-60. Held where they are, the legs reach them; a foot out of its leg's reach is re-placed at any
    distance (``spent``, below). Standing, a foot is re-placed only while every other foot is down
    (:func:`_others_down`); a stop's foot ``STOPPING`` off that the stop could not re-place (the other foot not yet
    down, or the walk's fading weight still rolling it a little) is kept ``pending`` and steps once it can, in the
    stop or, past it, where the verbs hold it flat, while the creature stands and it is still that far: parked
    11-12 cm off, it stepped mid-reach as the reach's stance took it past 15 cm (5.6-7.7x the legs' own)."""
    p = feet.planter
    held = frame.held & ~feet.replanting
    swinging = np.where(frame.held, 0.0, frame.swing)
    swing = np.where(feet.replanting, _step_lift(p, swinging), frame.swing)  # a foot re-placed steps: at the least lift
    _rebase_hover(feet, frame)
    phases = (held, frame.roll, swing, frame.lifts, frame.eased, frame.held)  # (re-placed: the verbs hold, it is free)
    out = p.step(frame.rotations, frame.translations, None, dt, phases)
    _take_levels(feet, frame)
    # A foot the planter let go out of its leg's reach (``spent``) that the verbs hold flat is re-placed, a step
    # from its release: it stayed free until the verbs' hold ended, and a stand's, a bow's or a guide's never does
    # (after a stop cut short by a gesture it followed the body along the floor for the rest of the standing: 60 cm
    # at once, then 10 cm at each later gesture).
    feet.replanting |= p.spent & (p.mode == FREE) & frame.held & (frame.roll == 0.0)
    if feet.replanting.any():
        # Let go this frame (free, its height's offset just begun): its horizontal offset starts STEP_DELAY later,
        # where it was let go until then (the lift comes first: the planter holds it there, ``FootPlanter``); its
        # height does not wait. It was kept moving against the verbs' velocity at its release, but a stop's walk
        # slows as it fades: a foot let go 14 mm a frame slid 9 mm along the floor in the next, when its verbs' moved 5.
        going = feet.replanting & (p.mode == FREE) & (p.since[..., 1] == 0.0)
        for a in (0, 2):
            p.offset_vel[..., a] = np.where(going, 0.0, p.offset_vel[..., a])
            p.since[..., a] = np.where(going, -STEP_DELAY, p.since[..., a])
        settled = np.linalg.norm(p._offset(), axis=-1) < REPLANTED
        feet.replanting &= ~((p.mode == FREE) & settled & (p.since[..., 0] > 0))
    away = p.prev_free - p.target
    gap = np.hypot(away[..., 0], away[..., 2])
    flat = (p.mode == BALL) & (p.turn == 0.0)
    far = flat & (gap > np.where(alone, REPLANT, LEFT_BEHIND)[:, None])
    if standing is not None:
        stopping = feet.cyclic[frame.verbs[:, 0]] & ~feet.cyclic[frame.verbs[:, 1]]  # a cycle blending into a stand
        limit = np.where(stopping, STOPPING, STANDING)[:, None]
        # Standing, a foot the verbs hold flat is flat, whatever the planter's own roll (a ball raised over its level).
        level = (p.mode == BALL) & (frame.roll == 0.0)
        # A stop's foot STOPPING off, held down by the planter (BALL), steps though the walk's fading weight still
        # rolls it a little, once the other is down, in the stop or after it while the creature stands that far off.
        wants = (p.mode == BALL) & (gap > STOPPING)
        feet.pending[:] = np.where(stopping[:, None], wants, feet.pending & wants & standing[:, None])
        waited = feet.pending & (level | stopping[:, None])  # (past the stop, only where the verbs hold it flat)
        steps = (_standing_far(level, away, gap, limit) | waited) & _others_down(p.mode, feet.replanting)
        feet.replanting |= np.where(standing[:, None], steps, far)
        feet.pending &= ~feet.replanting
    else:
        feet.replanting |= far
    return out


def _level(levels: np.ndarray, verbs: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """The contact level ``(C, L)`` of each foot in the verbs shown, ``verbs (C, 2)`` blended by ``alpha (C,)`` as the
    pose is, from ``levels (C, L, V)``; NaN where a verb with any weight has none yet."""
    rows = np.arange(len(verbs))
    la, lb = levels[rows, :, verbs[:, 0]], levels[rows, :, verbs[:, 1]]
    a = alpha[:, None]
    return np.where(a >= 1.0, la, np.where(a <= 0.0, lb, a * la + (1.0 - a) * lb))


def _rebase_hover(feet: GraphFeet, frame: Frame) -> None:
    """A free foot's contact level (``FootPlanter.hover``, which lowers its swing so that it lands on the floor) moved by
    as much as the levels of the verbs shown have moved since it was let go (:func:`_take_levels`).

    The planter takes a foot's level as it leaves the floor, from the verb that stood it there. A CMU run stands a
    foot 11 mm over its contact height, the walk 12 mm under it: a foot let go in a run and swung by the walk into
    which it slowed was lowered 23 mm too far, came down a frame early and ran on along the floor (48 mm, the walk's
    own 20)."""
    p = feet.planter
    moved = _level(feet.levels, frame.verbs, frame.alpha) - feet.level0
    free = (p.mode == FREE) & np.isfinite(moved)
    p.hover[free] = feet.hover0[free] + moved[free]


def _take_levels(feet: GraphFeet, frame: Frame) -> None:
    """The contact level of each foot let go this frame, kept for the verb that stood it (where one verb has all the
    weight), and, for :func:`_rebase_hover`, with the verbs' levels then."""
    p = feet.planter
    gone = (p.mode == FREE) & (p.since[..., 1] == 0.0)
    if not gone.any():
        return
    a, b = frame.verbs[:, 0], frame.verbs[:, 1]
    one = np.where((frame.alpha >= 1.0) | (a == b), a, np.where(frame.alpha <= 0.0, b, -1))
    c, i = np.nonzero(gone & (one >= 0)[:, None])
    feet.levels[c, i, one[c]] = p.hover[c, i]
    feet.hover0[gone] = p.hover[gone]
    feet.level0[gone] = _level(feet.levels, frame.verbs, frame.alpha)[gone]


def _others_down(mode: np.ndarray, replanting: np.ndarray) -> np.ndarray:
    """Which feet ``(C, L)`` have every other foot down (held, not being re-placed): a standing creature steps one foot
    at a time. A stop's trailing foot, 15 cm from where the stand has it while the walk still swung the other, was let
    go before that one landed, and the body stood on neither foot for 0.2 s."""
    down = (mode != FREE) & ~replanting
    return down.sum(axis=1, keepdims=True) - down == mode.shape[1] - 1


def _standing_far(
    flat: np.ndarray, away: np.ndarray, gap: np.ndarray, limit: float | np.ndarray = STANDING
) -> np.ndarray:
    """Which held feet ``(C, L)`` of standing creatures to re-place: one ``limit`` from where the verbs have it
    (``STANDING``; ``STOPPING`` in a stop), or, with every foot held flat and the body gone ``SHIFTED`` from over
    them (their mean offset ``away (C, L, 3)``), the further one.

    A stop used to hold its feet to 15 cm like any stand: the walk's last stance foot, 9-14 cm from where the stand
    has it at sad valences, was held there through the stand and the gestures after it, until their own sway took it
    past 15 cm and it stepped in the middle of a gesture, its knee at 4-9x the stand's own legs (the most of the
    random scripts' windows over a bound). Re-placed at 9 cm in a stop it steps as the stop ends, in the stop's half
    second, at the walk's pace: the random scripts' windows over a bound (measured as then), seeds 300-329, 17 -> 10
    (legs 8 -> 4, hips 6 -> 2), 200-229 6 -> 6; held out (400-429, not used to choose 9 cm over 6 and 7.5) 10 -> 9.

    ``flat`` (:func:`plant`): held as a ball with the verbs' roll nothing. It was the planter's roll, which also rolls
    a ball its verb raises over the level found for it (``FootPlanter``, ``STILL_DOWN``): a stop's foot 14-16 cm from
    where the stand has it, the stand's foot a little higher there, was rolled 0.1-0.2 and so never flat, held with
    its heel lifted 0.3 rad for the leg to reach it through a bow, a stand and a reach (8 s), and stepped as a guide
    began (2.8x the legs' own). Random scripts: 200-229 6 -> 6, 300-329 9 -> 9, 400-429 (where it was found) 8 -> 4;
    seeds 500-529, used for neither change: 20 before the stop's 9 cm, 16 with it, 14 with this (the README counts
    both in turn under today's measures)."""
    mean = away.mean(axis=1)
    shifted = flat.all(axis=1) & (np.hypot(mean[:, 0], mean[:, 2]) > SHIFTED)
    further = np.arange(gap.shape[1])[None, :] == gap.argmax(axis=1)[:, None]
    return flat & ((gap > limit) | (shifted[:, None] & further))
