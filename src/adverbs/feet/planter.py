"""The foot planter: a verb's constraints enforced on its motion, one frame at a time (§3.3).

:class:`FootPlanter` keeps, for each of ``C`` creatures and each constrained effector, what the
planting needs to remember between frames, and :meth:`FootPlanter.step` advances them all by one
frame. Offline planting (:func:`adverbs.feet.offline.plant_feet`, :func:`~adverbs.feet.offline.plant_feet_many`)
is the same planter run over every frame of a clip, then one batched IK solve: it gives the same motion as
feeding the frames one by one (``tests/test_feet.py``).

Per effector, with ``g`` the frame's generic time and :class:`~adverbs.verb.constraints.Hold` ``h``
(its times blended at the creature's adverb point from the examples' own contacts):

* **Heel strike** (``g`` reaches ``h.open``): the ankle is held where it is shown, at its contact
  height above the floor, while the foot rolls down as the verb turns it. A foot that lands on its
  ball (a run) skips this.
* **Foot flat** (the ball reaches the floor): the ball is held where it is, ``h.height`` (its height
  above the sole, from the examples) above the floor under it — the floor, not the verb, says how high
  a planted foot is — and so is the foot's orientation, so the heel stays where it landed.
* **Roll-off** (from ``h.heel_off``, or as soon as the verb lifts the ball off its own level): the foot
  turns back to the verb's orientation about the held ball (smoothstep), the ball rising as the verb
  raises it; it is let go at ``h.close`` (toe-off), or once the verb has lifted it ``LIFTS_OFF``.
* **Landing early** (under a decaying offset of the whole pose, a blend's): a foot in the landing end of its
  swing that the verbs already have under its contact height lands from there, as at a hold, though theirs has
  not opened; it came down at the offset's speed as well as the verb's.
* **Free** (swing, flight): the verb's effector, lowered near the ground by how far the verb's stance
  hovered over its floor (at extrapolated adverbs the verb can lift the whole stance), never below the
  floor plus the contact height. The verb's level is the lowest its foot got over the hold (rolling off
  included: a toe joint dips as the foot pivots on its ball), so the foot clears the ground by as much
  as the verb's own does, and a rolling ball rises over that level as the verb's rises over it. A cyclic
  verb's released ball also swings at least ``SWING_LIFT`` (3 cm) over its contact height, joined smoothly
  (:func:`_smooth_max`) and faded out over the last ``SWING_LANDING`` (30%) of the swing before the next
  landing (:func:`swing_lifts`): where the capture drags its toe through the swing (a pivot turn, a shuffling
  jog), the foot is lifted off the floor instead of sliding along it; where the verb's swing is higher, the
  lift changes nothing.
* **Switches are inertialized**: the gap between where the foot was shown and where the new rule puts
  it is an offset that decays to zero as a critically damped spring (``x(t) = (x₀ + (v₀ + y x₀) t)
  e^{−y t}``). At release ``v₀`` cancels the verb's horizontal foot velocity, so the foot leaves from
  rest, and the vertical part decays faster than the horizontal one, so it lifts before it travels; the
  turn the foot still had to make decays the same way. An offset set to begin later (a re-placed foot's,
  ``graph.planted``) holds the foot where it is until then. At landing nothing slides: only the height settles.
  A released foot's height offset is kept over the floor under where it is shown: up a slope, the
  horizontal offset carries it over other ground than the verb's foot is over.

The legs are then solved by :func:`adverbs.kinematics.ik.solve` with each foot's target and wanted
orientation. The root is lowered where a leg cannot reach its target and eases back up (``DROP_HALFLIFE``).
Heights follow the floor: a point the verb carries ``h`` above its own flat ground is put ``h`` above
the floor under it; the pelvis rides the floor under itself, or under the lower foot up a slope; on a
floor that is not flat the feet are tilted to the surface.
"""

from __future__ import annotations


import numpy as np

from ..errors import AdverbsError
from ..interp import timewarp
from ..kinematics import ik, quat
from ..kinematics.fk import forward_kinematics, path_to
from ..kinematics.floor import FlatFloor, Floor, HeightMapFloor, SlopeFloor, tilt
from ._planting_scalars import FLAT_TO_THE_END, SWING_LANDING
from ..verb.tables import Verb

LIFT_HALFLIFE = 0.015  # seconds: the vertical part of a released foot's offset halves this fast
SWING_HALFLIFE = 0.1  # seconds: the horizontal part, slower, so the foot lifts before it travels
DROP_HALFLIFE = 0.1  # seconds: a lowered root comes back up no faster than this decay
SETTLE_HALFLIFE = 0.03  # seconds: a landing foot's height settles onto the floor this fast
HEEL_LIFT = 0.8  # radians (46°): the most a held foot's heel is lifted about its ball for a leg to reach it
HEEL_STEEPEST = 1.4  # radians (80°): ... and never so far that its ankle stands higher than this over the ball
TRAILING = 0.1  # metres: a held ball this far behind its hip (along the foot) may have its heel lifted in full
INSIDE = 1.0 - 1e-9  # a free foot out of reach is brought this far inside it (the IK then does not lower the root)
_LN2 = float(np.log(2.0))


def _spring(x0: np.ndarray, v0: np.ndarray, t: np.ndarray, halflife: np.ndarray | float) -> np.ndarray:
    """Critically damped decay of an offset ``x0`` with velocity ``v0`` after ``t`` seconds; before it starts (``t < 0``),
    ``x0``: a re-placed foot's step travels once it has lifted (``graph.planted``), and until then the planter keeps
    ``x0`` where it holds the foot still (:meth:`FootPlanter.targets_reference`)."""
    y = 2.0 * _LN2 / halflife
    after = np.maximum(t, 0.0)
    return np.where(t < 0.0, x0, (x0 + (v0 + y * x0) * after) * np.exp(-y * after))


_HALFLIVES = np.array([SWING_HALFLIFE, LIFT_HALFLIFE, SWING_HALFLIFE])
_AT_REST = np.array([1.0, 0.0, 1.0])  # which parts of the verb's velocity a released foot starts without
FREE, HEEL, BALL = 0, 1, 2  # what a foot is doing: swinging, landed on its heel, on its ball
SWING_CLEARANCE = 0.1  # metres above the verb's own contact level where its swing is no longer lowered
LANDING = 0.1  # m/s: a foot coming down faster than this under a decaying offset can land early (targets)
LIFTED = 0.02  # metres above its contact height: a released foot this high has left the ground
SWING_LIFT = 0.03  # metres: the least a cyclic verb's swing lifts a released ball over its contact height
LIFT_BLEND = 0.02  # metres: within this of the least lift, the verb's swing joins it smoothly (no kink)
LIFTS_OFF = 0.02  # metres: a rolling foot's ball this far above its contact level is lifting off
STILL_DOWN = 0.005  # metres: a held ball the verb raises less than this over its level is still down
TOE_LANDS = 0.003  # metres: a rolling foot's ball this close to its contact height has landed
RISE = 0.3  # m/s: under a decaying offset, how fast the examples' lift under a free foot may rise from where it was
EXAMPLE_SLACK = 0.002  # metres: a swing this little under its examples' blended lift is left as the verb has it (the
# examples' lifts are sampled 128 times a cycle and read linearly between: within 1.1 mm of their own on the shipped verbs)


class FootPlanter:
    """Planted feet for ``creatures`` creatures of one verb, advanced one frame at a time.

    State per creature and effector ``(C, L)``: what the foot is doing (``mode``: :data:`FREE`,
    :data:`HEEL`, :data:`BALL`) and how far it has rolled off (``turn``), its target and held
    orientation, the offset being decayed (start, velocity, time since), the turn left over from its
    release, the verb's contact level (``hover``) and the verb's effector position in the previous frame
    (for its velocity); per creature, the root drop. ``weights (C, E)`` set the hold times (the
    examples' own, blended at each creature's adverb point); without them, their mean.

    :meth:`targets`, :meth:`reach` and :meth:`step` run a compiled loop (:mod:`._planting_kernel`) on a
    flat floor, a slope or a height map; their ``*_reference`` methods are the readable NumPy versions, which
    any other floor (a :class:`~adverbs.kinematics.floor.FunctionFloor`) and ``compiled=False`` use. The two
    agree to rounding (``tests/test_planting_kernel.py``).
    """

    def __init__(
        self,
        verb: Verb,
        creatures: int = 1,
        floor: Floor | None = None,
        weights: np.ndarray | None = None,
        compiled: bool = True,
    ):
        if not verb.constraints:
            raise AdverbsError(f"verb {verb.name!r} has no constraints: nothing to plant")
        self.verb = verb
        self.floor = FlatFloor(verb.floor) if floor is None else floor
        self.chains = verb.leg_chains
        self.tips = np.array(effector_joints(verb))
        self.heights = np.array([np.nan if h.height is None else h.height for h in verb.holds])
        self.opens = np.array([h.open for h in verb.holds])
        self.heel_heights = np.array([np.nan if h.heel_height is None else h.heel_height for h in verb.holds])
        c, n = int(creatures), len(verb.holds)
        if c < 1:
            raise AdverbsError(f"creatures must be at least 1, got {creatures}")
        self.creatures = c
        if weights is None:  # the holds' mean times
            self.times = np.tile([h.times for h in verb.holds], (c, 1, 1))
        else:
            self.set_weights(weights)
        self.started = False
        self.mode = np.full((c, n), FREE)
        self.turn = np.zeros((c, n))
        self.target = np.zeros((c, n, 3))
        self.held_rot = np.tile(np.eye(3), (c, n, 1, 1))
        self.offset = np.zeros((c, n, 3))
        self.offset_vel = np.zeros((c, n, 3))
        self.since = np.zeros((c, n, 3))
        self.spent = np.zeros((c, n), dtype=bool)  # this hold's foot was let go early: the verb lifted it
        self.drop = np.zeros(c)  # how far the root is lowered (decaying once no leg needs it)
        self.heel = np.zeros((c, n))  # how far a held foot's heel is lifted about its ball beyond the verb's (radians)
        self.rising = np.zeros((c, n))  # how far a rolling ball is raised with the verb's
        self.rel_vec = np.zeros((c, n, 3))  # a released foot's orientation relative to the verb's (rotation vector)
        self.rot_since = np.full((c, n), 1e9)  # seconds since then (long ago: nothing left)
        self.settle = np.zeros((c, n), dtype=bool)  # the offset being decayed is a landing's
        self.hover = np.zeros((c, n))  # the verb's contact level, lowering the free foot
        self.ground = np.zeros((c, n))  # its lowest point over the current hold: the next hover
        self.prev_free = np.zeros((c, n, 3))
        self.kept = np.full((c, n), np.nan)  # a free foot's least examples' lift under a decaying offset (NaN: none)
        kernel_floor = _compiled_floor(self.floor) if compiled else None
        self._compiled = None if kernel_floor is None else _Compiled(self, kernel_floor)

    @property
    def shown_mode(self) -> np.ndarray:
        """What each foot is doing as shown ``(C, L)``, what reports record: ``mode``, but a foot let go this frame
        (:meth:`reach_reference` found it out of reach on its toes; the next frame releases it) as :data:`FREE`:
        its target is no longer where it was held."""
        return np.where(self.spent & (self.mode != FREE), FREE, self.mode)

    @property
    def rolled(self) -> np.ndarray:
        """How far each foot is off flat ``(C, L)``, what reports record: the turn back to the verb's orientation
        (``turn``), or, where the planter lifted a heel for its leg to reach (:meth:`reach_reference`), that lift's
        share of ``HEEL_LIFT`` if more: a foot on its toes is not flat."""
        return np.maximum(self.turn, self.heel / HEEL_LIFT)

    # ----- the state machine ------------------------------------------------------------------
    def set_weights(self, weights: np.ndarray) -> None:
        """Hold times at the creatures' cardinal weights ``(C, E)`` (the examples' own, blended)."""
        self.times = self.verb.hold_times(np.broadcast_to(weights, (self.creatures, len(self.verb.examples))))

    def _tilt(self, xz: np.ndarray) -> np.ndarray:
        """The floor's tilt ``(..., 3, 3)`` under points ``xz (..., 2)`` (identity on a flat floor)."""
        if self.floor.is_flat:
            return np.broadcast_to(np.eye(3), xz.shape[:-1] + (3, 3))
        return tilt(self.floor.normal(xz))

    def targets(
        self,
        free_pos: np.ndarray,
        free_rot: np.ndarray,
        generic: np.ndarray | None,
        dt: float | np.ndarray,
        phases: tuple[np.ndarray, ...] | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`targets_reference`, compiled where the floor allows."""
        if self._compiled is None:
            return self.targets_reference(free_pos, free_rot, generic, dt, phases)
        return self._compiled.targets(free_pos, free_rot, generic, dt, phases)

    def targets_reference(
        self,
        free_pos: np.ndarray,
        free_rot: np.ndarray,
        generic: np.ndarray | None,
        dt: float | np.ndarray,
        phases: tuple[np.ndarray, ...] | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Advance the state by one frame; the effectors' targets ``(C, L, 3)`` and wanted foot orientations ``(C, L, 3, 3)``.

        ``free_pos (C, L, 3)`` and ``free_rot (C, L, 3, 3)``: where the verb puts each effector and the
        global orientation of its foot (the chain's end) this frame; ``generic (C,)``: the frame's
        generic time; ``dt``: seconds since the previous frame (one for all, or ``(C,)``). The orientations
        include the floor's tilt. ``phases``: instead of ``generic``, whether each hold is open ``(C, L)``, how
        far each foot has rolled off ``(C, L)`` and, optionally, how much of the least swing lift applies
        ``(C, L)`` (:func:`swing_lifts`; none if not given), the examples' lift ``(C, L)`` (:func:`example_lifts`;
        none if not given), optionally, the share ``(C,)`` of it a decaying offset leaves (``Frame.eased``; 1:
        all of it) and whether the verbs hold each foot ``(C, L)`` where the first keeps one free (a re-placed foot,
        which does not land early; the first if not given), from elsewhere (a verb graph's blend of two verbs).
        Given ``generic``, the examples' lift is not kept: a verb sampled by its clock fades each later cycle's seam,
        which its examples' lifts do not follow.

        Under a decaying offset (a share below 1) a free foot is kept over that share of the examples' lift, or over
        a floor rising from where the foot was as the offset began (or as it was let go) at most ``RISE``, whichever
        is higher, and never over the whole lift. Kept over the share alone, a walk -> run cut short by a command
        (the run played at once under the offset of the walk's pose) brought the swinging foot down early: the offset
        took the run's foot 30-45 mm under the floor and it skimmed it at 3-7 m/s, 24-187 mm over the walk's and the
        run's own low travel in 10 of 14 random scripts (then 2, 28 and 40 mm: none since feet land early, below).
        Kept over the whole lift, a foot the walk had just lifted jumped from 12 to 82 mm in one frame.
        """
        verb, floor, tip = self.verb, self.floor, self.chains.tip_offset
        follows = np.broadcast_to(np.isnan(self.heights), self.mode.shape)  # effectors that keep the verb's height
        height = np.where(follows, 0.0, self.heights)
        if phases is None:
            g = np.asarray(generic, dtype=float)[:, None]
            inside, turn = hold_modes(self.verb.cyclic, g, self.opens, self.times)
            swing = swing_lifts(self.verb.cyclic, g, self.opens, self.times)
            examples = np.full(self.mode.shape, -np.inf)
        else:
            inside, turn = (np.asarray(x) for x in phases[:2])
            swing = np.asarray(phases[2], dtype=float) if len(phases) > 2 else np.zeros(self.mode.shape)
            examples = np.asarray(phases[3], dtype=float) if len(phases) > 3 else np.full(self.mode.shape, -np.inf)
        eased = np.ones((self.creatures, 1))  # the examples' lift's share under a decaying offset (Frame.eased)
        if phases is not None and len(phases) > 4 and phases[4] is not None:
            eased = np.asarray(phases[4], dtype=float)[:, None]
        hold = inside  # the verbs' own holds, where phases keep a foot free while they hold it (a re-placed one)
        if phases is not None and len(phases) > 5 and phases[5] is not None:
            hold = np.asarray(phases[5], dtype=bool)
        # How far the verb's effector is above its contact height (its own floor at these adverbs).
        lift = np.where(follows, 0.0, free_pos[..., 1] - verb.floor - height)
        if not self.started:  # the verb's level from the feet that are down now, else none
            down = np.where(inside, lift, np.inf).min(axis=1, keepdims=True)
            self.hover[:] = np.where(np.isfinite(down), down, 0.0)
            self.ground[:] = np.inf
            self.prev_free[:] = free_pos
            self.started = True
        dt = np.broadcast_to(np.asarray(dt, dtype=float), (self.creatures,))[:, None, None]
        # An offset not yet begun (a re-placed foot before it lifts, ``graph.planted``) holds the foot where it is: it
        # takes up the verb's motion.
        self.offset -= np.where(self.since < 0.0, free_pos - self.prev_free, 0.0)
        self.since += dt
        vel = (free_pos - self.prev_free) / np.where(dt > 0, dt, np.inf)
        # Landing early: under a decaying offset (``eased`` below 1) the verbs can bring a foot down to the floor before
        # their hold opens, and it came in low at the offset's speed as well as the verb's (a run after a walk cut
        # short ran its toe 8 cm along the floor in the frame before its hold). A foot in the landing end of its
        # swing (``swing`` between 0 and 1) that the verbs have under its contact height lands from there, as at a hold
        # (on its heel while its toe is up), not rolled.
        early = (eased < 1.0) & ~hold & (swing > 0.0) & (swing < 1.0) & (lift < 0.0) & ~follows
        early &= (self.mode != FREE) | (vel[..., 1] < -LANDING)  # coming down (a standing foot re-placed is not)
        inside = inside | early
        turn = np.where(early, 0.0, turn)
        # A ball the verb lifts off its level rolls the foot off it too, whatever the examples' heel-off says.
        # Held, over the level this hold has found so far (the lowest the verb's foot got since it landed,
        # rolling off included): the ball rises as far over it as the verb's does, and leaves at that height.
        level = np.where((self.mode != FREE) & np.isfinite(self.ground), np.minimum(self.ground, lift), self.hover)
        raised = _lowered(lift, level)
        turn = np.where(self.mode == BALL, np.maximum(turn, _smoothstep((raised - STILL_DOWN) / (LIFTS_OFF - STILL_DOWN))), turn)
        # A rolling foot the verb already lifts off (its ball LIFTS_OFF above its own contact level) is let go
        # before the hold's toe-off, and not held again until the next hold.
        self.spent &= inside
        self.spent |= (self.mode == BALL) & (turn > 0.0) & (raised >= LIFTS_OFF)
        inside = inside & ~self.spent
        opening, closing = inside & (self.mode == FREE), ~inside & (self.mode != FREE)
        self.hover = np.where(closing & np.isfinite(self.ground), self.ground, self.hover)
        raised = np.where(closing, _lowered(lift, self.hover), raised)  # the let-go feet's new level
        level = np.where(closing, self.hover, level)
        # Where the free rule puts the foot: the verb's, lowered by its hover, no lower than its examples lift it
        # there (blended at these adverbs: a blend of leg rotations swings lower than any of them), on the floor,
        # and at least the swing's least lift over it (a verb that drags its foot through the swing has it lifted).
        base = free_pos.copy()
        # Under a decaying offset the examples' lift is eased in (``eased``, its share), but no lower than a floor
        # that rises from where a free foot was, at most RISE: a foot swinging high as the offset was taken stays up
        # (``kept``: that floor, a frame ago; NaN where the foot was held or no offset eased the lift).
        dtl = dt[..., 0]
        cap = np.where(np.isnan(self.kept), lift, self.kept + RISE * dtl)
        easing = (eased < 1.0) & np.isfinite(examples)
        examples = np.where(easing, np.minimum(examples, np.maximum(examples * eased, cap)), examples)
        swung = raised + _ramp(_lowered(examples, level) - raised - EXAMPLE_SLACK, LIFT_BLEND)
        # (Not for a foot about to land; but one its verbs hold past heel-off while it is still in the air is lifting:
        # a stop turned back into the walk gave its landing foot the walk's hold, and it dropped 20 mm in a frame.)
        lifting = inside & (self.mode == FREE) & (turn > 0.0) & (swing > 0.0)
        # (A foot landing early keeps this frame's least lift: it lands from where it was.)
        least = np.where(follows | (inside & ~lifting & ~early), -np.inf, SWING_LIFT * swing)
        base[..., 1] = floor.height(free_pos[..., [0, 2]]) + height + _smooth_max(swung, least, LIFT_BLEND)
        free_wanted = self._tilt(base[..., [0, 2]]) @ free_rot
        self.rot_since += dt[..., 0]
        # Rolling off: the ball rises as the verb's does over its contact level, weighted in as the heel lifts.
        self.rising = np.where(follows, 0.0, np.maximum(raised, 0.0) * turn)
        shown, wanted = self._shown(base, height, follows, free_rot, free_wanted, self.turn)  # before anything switches
        if closing.any():  # let go: what the foot's orientation had still to turn decays from here
            rel = wanted[closing] @ np.swapaxes(free_wanted[closing], -1, -2)
            q = quat.from_matrix(rel)
            self.rel_vec[closing] = quat.log(np.where(q[..., 3:] < 0.0, -q, q))  # the short way round
            self.rot_since[closing] = 0.0
            self.offset[closing] = shown[closing] - base[closing]  # let go from where it was shown
            # Its height as a height over the floor under it: on a slope the decaying horizontal offset
            # carries the foot over other ground than the verb's foot is over.
            self.offset[closing, 1] -= self._ground_shift(shown, base)[closing]
            self.offset_vel[closing] = -vel[closing] * _AT_REST  # leaves from rest horizontally, rises as the verb lifts it
            self.since[closing] = 0.0
            self.settle[closing] = False
            self.mode[closing] = FREE
        # A landing foot rolls down from its heel unless its ball is down already (a run's forefoot strike)
        # or the heel is lifting (a foot found down in mid-stance when planting starts).
        has_heel = ~follows & ~np.isnan(self.heel_heights)
        low = shown[..., 1] - floor.height(shown[..., [0, 2]]) - height <= TOE_LANDS
        rocking = opening & has_heel & ~low & (turn == 0.0)
        opening &= low | (turn == 0.0)  # found rolling off with the ball already up: it is lifting, leave it free
        if rocking.any():  # heel strike: the ankle is held where it is shown, at its height over the floor
            ankle = shown[rocking] - np.einsum("nij,nj->ni", free_wanted[rocking], np.broadcast_to(tip, shown.shape)[rocking])
            self._land(rocking, ankle, np.broadcast_to(self.heel_heights, rocking.shape)[rocking])
            self.mode[rocking] = HEEL
            shown, _ = self._shown(base, height, follows, free_rot, free_wanted, turn)
        # The ball is down once the rolling foot brings it to the floor (or, at the latest, at heel-off).
        low = shown[..., 1] - floor.height(shown[..., [0, 2]]) - height <= TOE_LANDS
        balls = (opening & ~rocking) | ((self.mode == HEEL) & (low | (turn > 0.0)))
        if balls.any():  # the ball and the foot's orientation are held
            self._land(balls, shown[balls], np.where(follows[balls], np.nan, height[balls]))
            self.held_rot[balls] = self._released_rot(free_rot)[balls]
            self.mode[balls] = BALL
        # The verb's own level at these adverbs: the lowest its foot gets while held, taken at toe-off.
        held = self.mode != FREE
        self.ground = np.where(opening, np.inf, self.ground)
        self.ground = np.where(held, np.minimum(self.ground, lift), self.ground)
        self.turn = turn
        self.prev_free[:] = free_pos
        self.kept = np.where(easing & (self.mode == FREE), examples, np.nan)
        shown, wanted = self._shown(base, height, follows, free_rot, free_wanted, turn)
        return shown, wanted

    def _land(self, which: np.ndarray, point: np.ndarray, height: np.ndarray) -> None:
        """Hold ``point (n, 3)`` for the effectors in ``which``: where it is, ``height`` above the floor (NaN:
        where it is); the height it had is an offset that settles."""
        target = point.copy()
        level = self.floor.height(point[:, [0, 2]]) + np.where(np.isnan(height), 0.0, height)
        target[:, 1] = np.where(np.isnan(height), point[:, 1], level)
        self.target[which] = target
        self.offset[which] = 0.0
        self.offset[which, 1] = np.maximum(point[:, 1] - target[:, 1], 0.0)  # settles down, never up from below
        self.offset_vel[which] = 0.0
        self.since[which] = 0.0
        self.settle[which] = True

    def _released_rot(self, free_rot: np.ndarray) -> np.ndarray:
        """The verb's foot orientations turned by what is left of the turn each had when it was let go."""
        k = _spring(1.0, 0.0, self.rot_since, SWING_HALFLIFE)
        k = np.where(k < 1e-9, 0.0, k)  # long let go: nothing left to turn
        if not k.any():
            return free_rot
        return quat.rotvec_matrix(self.rel_vec * k[..., None]) @ free_rot

    def _shown(self, base, height, follows, free_rot, free_wanted, turn) -> tuple[np.ndarray, np.ndarray]:
        """Where each effector is shown in its current mode, and its foot's wanted orientation."""
        free_rot = self._released_rot(free_rot)
        free_wanted = self._tilt(base[..., [0, 2]]) @ free_rot
        shown = base + self._offset()
        under = self.floor.height(shown[..., [0, 2]])
        shown[..., 1] += np.where(follows, 0.0, under - self.floor.height(base[..., [0, 2]]))  # see _ground_shift
        low = under + height
        shown[..., 1] = np.where(follows, shown[..., 1], np.maximum(shown[..., 1], low))
        held_at = self._shown_held()
        held_tilt = self._tilt(self.target[..., [0, 2]])
        wanted = np.where(
            (self.mode == FREE)[..., None, None],
            free_wanted,
            held_tilt @ np.where((self.mode == HEEL)[..., None, None], free_rot, _turn(self.held_rot, free_rot, turn)),
        )
        wanted = _heel_turn(wanted, self.chains.heel_axis, np.where(self.mode == BALL, self.heel, 0.0))
        rocker = held_at + np.einsum("...ij,...j->...i", wanted, self.chains.tip_offset)
        shown = np.where((self.mode == BALL)[..., None], held_at, np.where((self.mode == HEEL)[..., None], rocker, shown))
        return shown, wanted

    def _ground_shift(self, shown: np.ndarray, base: np.ndarray) -> np.ndarray:
        """How much higher the floor is under ``shown`` than under ``base`` (``(C, L)``; 0 on a flat floor)."""
        return self.floor.height(shown[..., [0, 2]]) - self.floor.height(base[..., [0, 2]])

    def _offset(self) -> np.ndarray:
        """The decaying offset of the free rule now, ``(C, L, 3)`` (zero where a landing's is decaying)."""
        hl = np.where(self.settle[..., None], SETTLE_HALFLIFE, _HALFLIVES)
        x = _spring(self.offset, self.offset_vel, self.since, hl)
        return np.where(self.settle[..., None], 0.0, x)

    def _held_offset(self) -> np.ndarray:
        """The decaying height offset of a landing foot now, ``(C, L, 3)``."""
        x = _spring(self.offset, self.offset_vel, self.since, SETTLE_HALFLIFE)
        return np.where(self.settle[..., None], x, 0.0)

    def _shown_held(self) -> np.ndarray:
        """Where a held foot is shown: its target plus the landing's settling height, and, as it rolls off its
        ball, raised as the verb raises it (``rising``), so it leaves the ground with the verb's knee."""
        out = self.target + self._held_offset()
        out[..., 1] += np.where(self.mode == BALL, self.rising, 0.0)
        return out

    # ----- one frame, legs solved -------------------------------------------------------------
    def step(
        self,
        rotations: np.ndarray,
        translations: np.ndarray,
        generic: np.ndarray | None,
        dt: float,
        phases: tuple[np.ndarray, ...] | None = None,
    ) -> tuple[np.ndarray, np.ndarray, ik.IKResult]:
        """:meth:`step_reference`, compiled where the floor allows: one call for FK, the state machine and IK."""
        if self._compiled is None:
            return self.step_reference(rotations, translations, generic, dt, phases)
        return self._compiled.step(rotations, translations, generic, dt, phases)

    def step_reference(
        self,
        rotations: np.ndarray,
        translations: np.ndarray,
        generic: np.ndarray | None,
        dt: float,
        phases: tuple[np.ndarray, ...] | None = None,
    ) -> tuple[np.ndarray, np.ndarray, ik.IKResult]:
        """Plant the feet of one frame of ``C`` creatures: local ``rotations (C, J, 4)``, ``translations (C, J, 3)``
        of the verb's motion, their generic times ``(C,)`` (or ``phases``, see :meth:`targets`) and the seconds
        since the previous frame.

        Returns the planted rotations and translations and the IK result (root drop, misses).
        """
        rotations = np.asarray(rotations, dtype=float)
        translations = np.asarray(translations, dtype=float)
        gpos, grot = forward_kinematics(self.verb.skeleton.parents, rotations, translations)
        free_pos, free_rot = gpos[:, self.tips], quat.to_matrix(grot[:, self.chains.end])
        targets, wanted = self.targets_reference(free_pos, free_rot, generic, dt, phases)
        rise = _rise(self.verb, self.floor, gpos[:, self.verb.encoding.body_root], targets)
        targets, wanted, drop = self.reach_reference(gpos[:, self.chains.upper], rise, targets, wanted, dt)
        risen = _ride_floor(self.verb, self.chains, translations, grot, rise)
        result = ik.solve(self.chains, rotations, risen, targets, self._tilts(wanted, free_rot), min_drop=drop)
        return result.rotations, result.translations, result

    def reach(
        self, hips: np.ndarray, rise: np.ndarray, targets: np.ndarray, wanted: np.ndarray, dt: float | np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`reach_reference`, compiled where the floor allows."""
        if self._compiled is None:
            return self.reach_reference(hips, rise, targets, wanted, dt)
        return self._compiled.reach(hips, rise, targets, wanted, dt)

    def reach_reference(
        self, hips: np.ndarray, rise: np.ndarray, targets: np.ndarray, wanted: np.ndarray, dt: float | np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """What the legs can reach from the hips ``(C, L, 3)`` (the verb's, before the pelvis rides up by ``rise
        (C,)``): the effectors' targets ``(C, L, 3)``, the feet's wanted orientations ``(C, L, 3, 3)`` and each
        creature's root drop ``(C,)``, as :func:`~adverbs.kinematics.ik.solve` reckons reach.

        1. **Heels.** Where the verb's body travels further over a held foot than the foot it shows (between
           examples, in a blend, over a loop's seam), the trailing leg cannot reach its ankle. A person rises
           onto the ball of the foot: a foot held on its ball is turned heel-up about the ball (which does not
           move) about ``LegChains.heel_axis`` as far as its leg needs, at most ``HEEL_LIFT`` and never with
           the ankle more than ``HEEL_STEEPEST`` over the ball; only a foot its hip has passed (in full from
           ``TRAILING`` behind it): a foot under the body that its leg cannot reach (a stand too tall for its
           legs) lowers the hips. A lifted heel comes down no faster than a ``DROP_HALFLIFE`` decay. ``heel``
           keeps the lift, so a foot let go leaves from the orientation it was shown in (:meth:`_shown` turns
           held feet by it). A foot rolling off ``TRAILING`` behind its hip that cannot be reached on its toes,
           or will not be by the next frame at the rate its lift grows, is let go (toe-off comes when the leg
           is straight): it is marked ``spent``, and the next frame releases it.
        2. **The root drop.** What a held foot still cannot reach lowers the root, let go no faster than a
           ``DROP_HALFLIFE`` decay, so the body does not spring up when a stretched leg lets its foot go.
        3. **Free feet.** A swinging foot (or one being let go) out of reach of the hips so lowered does not
           lower them: its target is raised until the leg reaches it (it lifts off the ground rather than
           sliding along it), or, where raising cannot do it, brought in along the line to its hip (a foot just
           let go, leaving from rest, trails the hips).
        """
        tip, reach, axis = self.chains.tip_offset, self.chains.reach, self.chains.heel_axis
        held = self.mode == BALL
        wanted = _heel_turn(wanted, axis, -np.where(held, self.heel, 0.0))
        arm = -np.einsum("...ij,...j->...i", wanted, tip)  # ball → ankle
        hips = hips + rise[:, None, None] * np.array([0.0, 1.0, 0.0])
        need = _heel_needed(targets - hips, arm, np.einsum("...ij,...j->...i", wanted, axis), reach)
        fade = np.exp(-_LN2 * np.broadcast_to(np.asarray(dt, dtype=float), self.drop.shape) / DROP_HALFLIFE)
        most = np.clip(HEEL_STEEPEST - np.arctan2(arm[..., 1], np.hypot(arm[..., 0], arm[..., 2])), 0.0, HEEL_LIFT)
        # Only a foot the hips have passed: one under the body (a stand too tall to reach its feet) lowers the hips.
        forward = -arm[..., [0, 2]] / np.maximum(np.hypot(arm[..., 0], arm[..., 2]), 1e-9)[..., None]
        behind = np.sum((hips - targets)[..., [0, 2]] * forward, axis=-1)
        most = most * _smoothstep(behind / TRAILING)
        # A foot rolling off behind the hips that its leg cannot reach on its toes, now or (at the rate the lift it
        # needs grows) by the next frame, is let go: the next frame releases it.
        going = held & (self.turn > 0.0) & (behind >= TRAILING) & (np.maximum(need, 2.0 * need - self.heel) > most)
        self.heel = np.where(held, np.minimum(np.maximum(need, self.heel * fade[:, None]), most), 0.0)
        self.spent |= going
        wanted = _heel_turn(wanted, axis, self.heel)
        arm = np.einsum("...ij,...j->...i", wanted, tip)  # ankle → effector
        d = targets - arm - hips
        across = np.hypot(d[..., 0], d[..., 2])
        need = np.where(across < reach, -d[..., 1] - np.sqrt(np.maximum(reach**2 - across**2, 0.0)), 0.0)
        loose = (self.mode == FREE) | going
        need = np.where(loose, 0.0, need).max(axis=-1)
        need = np.minimum(np.maximum(need, 0.0), ik.MAX_DROP * float(reach.min()))
        self.drop = np.maximum(need, self.drop * fade)
        d[..., 1] += self.drop[:, None]
        far = np.linalg.norm(d, axis=-1)
        inside = reach * INSIDE
        pull = loose & (far > inside)
        # Raised to the reach where it can be (a foot lifts off the ground rather than sliding), else along the line.
        across = np.hypot(d[..., 0], d[..., 2])
        up = pull & (across < inside) & (d[..., 1] < 0.0)
        scale = np.where(pull & ~up, inside / np.where(pull, far, 1.0), 1.0)
        d = d * scale[..., None]
        d[..., 1] = np.where(up, -np.sqrt(np.maximum(inside**2 - across**2, 0.0)), d[..., 1])
        dropped = hips - [0.0, 1.0, 0.0] * self.drop[:, None, None]
        return np.where(pull[..., None], dropped + d + arm, targets), wanted, self.drop.copy()

    @staticmethod
    def _tilts(wanted: np.ndarray, free_rot: np.ndarray) -> np.ndarray:
        """What the IK premultiplies each foot's orientation by to make it ``wanted``: ``wanted · free⁻¹``."""
        return wanted @ np.swapaxes(free_rot, -1, -2)


class _Compiled:
    """A :class:`FootPlanter`'s compiled path: its constants laid out once for :mod:`._planting_kernel`, and
    each frame's inputs checked and passed in with its state arrays (updated in place)."""

    def __init__(self, planter: FootPlanter, floor: tuple):
        k = _kernel()
        verb, chains, c, n = planter.verb, planter.chains, planter.creatures, len(planter.tips)
        self.planter = planter
        self.kernel = k
        self.floor = floor  # _compiled_floor(planter.floor)
        self.constants = k.constants(
            SWING_HALFLIFE, _LN2, _HALFLIVES, SETTLE_HALFLIFE, SWING_CLEARANCE, STILL_DOWN, LIFTS_OFF, TOE_LANDS,
            DROP_HALFLIFE, SWING_LIFT, LIFT_BLEND, HEEL_LIFT, HEEL_STEEPEST, INSIDE, TRAILING, EXAMPLE_SLACK, RISE,
            LANDING,
        )  # fmt: skip
        tip = np.ascontiguousarray(chains.tip_offset, dtype=float)
        self.legs = (planter.heights, planter.opens, planter.heel_heights, tip, np.ascontiguousarray(chains.heel_axis))
        reach = np.ascontiguousarray(chains.reach)
        self.max_drop = ik.MAX_DROP * float(reach.min())
        joints = (np.asarray(a, dtype=np.int64) for a in (chains.above, chains.upper, chains.middle, chains.end))
        axes = (np.ascontiguousarray(a, dtype=float) for a in (chains.hinge, chains.upper_offset, chains.end_offset))
        path = path_to(verb.skeleton.parents, planter.tips)  # FK runs through the feet's ancestors alone
        self.chain = (*joints, *axes, path, reach)
        self.ik_params = (float(chains.min_flex), ik.CONVERGED, self.max_drop)
        self.parents = np.asarray(verb.skeleton.parents, dtype=np.int64)
        self.tips = planter.tips.astype(np.int64)
        self.root = int(verb.encoding.body_root)
        self.dt = np.empty(c)
        self.no_generic = np.zeros(c)  # stand-ins for the inputs not given
        self.no_phases = (np.zeros((c, n), dtype=bool), np.zeros((c, n)), np.zeros((c, n)), np.full((c, n), -np.inf),
                          np.ones(c), np.zeros((c, n), dtype=bool))  # fmt: skip
        self.scratch: tuple | None = None  # step's arrays that are not returned

    def _state(self) -> tuple:
        """The planter's state arrays, in the order ``_planting_kernel`` takes them."""
        p = self.planter
        return (
            p.mode, p.turn, p.target, p.held_rot, p.offset, p.offset_vel, p.since, p.spent, p.rising, p.rel_vec,
            p.rot_since, p.settle, p.hover, p.ground, p.prev_free, p.drop, p.heel, p.kept,
        )  # fmt: skip

    def _frame(self, generic, dt, phases) -> tuple:
        """``generic, inside, turn, swing, examples, eased, hold, use_phases`` as the kernel takes them; ``dt`` into
        ``self.dt``."""
        self.dt[:] = dt
        shape = self.planter.mode.shape
        if phases is None:
            generic = np.asarray(generic, dtype=float)
            if generic.shape != shape[:1]:
                generic = np.ascontiguousarray(np.broadcast_to(generic, shape[:1]))
            return generic, *self.no_phases, False
        inside, turn = np.asarray(phases[0], dtype=bool), np.asarray(phases[1], dtype=float)
        swing = np.asarray(phases[2], dtype=float) if len(phases) > 2 else self.no_phases[2]
        examples = np.asarray(phases[3], dtype=float) if len(phases) > 3 else self.no_phases[3]
        given = (inside, turn, swing, examples)
        if any(x.shape != shape or not x.flags.c_contiguous for x in given):
            inside, turn, swing, examples = (np.ascontiguousarray(np.broadcast_to(x, shape)) for x in given)
        eased = self.no_phases[4] if len(phases) < 5 or phases[4] is None else np.asarray(phases[4], dtype=float)
        if eased.shape != shape[:1] or not eased.flags.c_contiguous:
            eased = np.ascontiguousarray(np.broadcast_to(eased, shape[:1]))
        hold = inside if len(phases) < 6 or phases[5] is None else np.asarray(phases[5], dtype=bool)
        if hold.shape != shape or not hold.flags.c_contiguous:
            hold = np.ascontiguousarray(np.broadcast_to(hold, shape))
        return self.no_generic, inside, turn, swing, examples, eased, hold, True

    def _times(self) -> np.ndarray:
        """The holds' times ``(C, L, 3)`` (``set_weights`` and ``plant_feet_many`` set them)."""
        return np.ascontiguousarray(self.planter.times, dtype=float)

    def targets(self, free_pos, free_rot, generic, dt, phases) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`FootPlanter.targets_reference` by ``_planting_kernel.advance``."""
        p = self.planter
        free_pos = np.ascontiguousarray(free_pos, dtype=float)
        free_rot = np.ascontiguousarray(free_rot, dtype=float)
        shown, wanted = np.empty(free_pos.shape), np.empty(free_rot.shape)
        self.kernel.advance(
            free_pos, free_rot, *self._frame(generic, dt, phases), self.dt, not p.started, self._times(),
            p.verb.cyclic, p.verb.floor, self.legs, self.constants, self.floor, self._state(), shown, wanted,
        )  # fmt: skip
        p.started = True
        return shown, wanted

    def reach(self, hips, rise, targets, wanted, dt) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`FootPlanter.reach_reference` by ``_planting_kernel.reach``."""
        self.dt[:] = dt
        p = self.planter
        hips, rise = (np.ascontiguousarray(a, dtype=float) for a in (hips, rise))
        targets, wanted = (np.array(a, dtype=float, order="C") for a in (targets, wanted))  # changed in place
        self.kernel.reach(hips, rise, targets, wanted, self.dt, self.legs[3], self.legs[4], self.chain[-1],
                          self.max_drop, self.constants, self._state())  # fmt: skip
        return targets, wanted, p.drop.copy()

    def step(self, rotations, translations, generic, dt, phases) -> tuple[np.ndarray, np.ndarray, ik.IKResult]:
        """:meth:`FootPlanter.step_reference` by ``_planting_kernel.step``: FK, the state machine and IK in one call."""
        p = self.planter
        rot = np.array(rotations, dtype=float, order="C")  # planted in place
        trans = np.array(translations, dtype=float, order="C")
        c = rot.shape[0]
        if self.scratch is None or self.scratch[0].shape != trans.shape:  # FK, targets, wanted orientations
            n = len(self.tips)
            self.scratch = (np.empty(trans.shape), np.empty(rot.shape), np.empty((c, n, 3)), np.empty((c, n, 3, 3)))
        drop, residual = np.empty(c), np.empty((c, len(self.tips)))
        finite = self.kernel.step(
            self.parents, rot, trans, *self._frame(generic, dt, phases), self.dt, not p.started, self._times(),
            p.verb.cyclic, p.verb.floor, self.tips, self.root, self.legs, self.constants, self.floor, self._state(),
            self.chain, self.ik_params, (*self.scratch, drop, residual),
        )  # fmt: skip
        p.started = True
        if not finite:
            raise AdverbsError("IK targets must be finite (got NaN or infinity)")
        return rot, trans, ik.IKResult(rot, trans, drop, residual > ik.MISS, residual)


def _compiled_floor(floor: Floor) -> tuple | None:
    """``floor`` as ``_planting_kernel`` takes it (``(kind, params, tilt, gx, gz, grid)``), or ``None`` if it cannot
    (a :class:`~adverbs.kinematics.floor.FunctionFloor`, or a subclass with heights of its own)."""
    none, no_grid = np.zeros(0), np.zeros((0, 0))
    if type(floor) is FlatFloor or type(floor) is SlopeFloor:  # a plane: one tilt everywhere
        gradient, d = (0.0, (0.0, 0.0)) if floor.is_flat else (floor.gradient, floor.direction)
        params = np.array([floor.level, gradient, d[0], d[1], floor.step])
        plane_tilt = np.eye(3) if floor.is_flat else tilt(floor.normal(np.zeros(2)))
        return 0, params, plane_tilt, none, none, no_grid
    if type(floor) is HeightMapFloor:
        params = np.array([0.0, 0.0, 0.0, 0.0, floor.step])
        return 1, params, np.eye(3), floor.x, floor.z, floor.heights
    return None


_KERNEL = None


def _kernel():
    """Compile the planter's loop on first use (cached on disk by numba), so importing adverbs stays quick."""
    global _KERNEL
    if _KERNEL is None:
        from . import _planting_kernel

        _KERNEL = _planting_kernel
    return _KERNEL


def hold_modes(cyclic: bool, g: np.ndarray, opens: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Whether each hold is open at generic times ``g (..., 1)``, given its ``opens (L,)`` and ``times (..., L, 3)``
    (foot flat, heel-off, toe-off): ``(..., L)`` bool, and how far each foot has turned back to the verb's
    orientation (0 until heel-off, 1 at toe-off; smoothstep; a hold whose heel-off is its toe-off, a stand's, does not
    roll: 0 while open, 1 after)."""
    heel, close = times[..., 1] - opens, times[..., 2] - opens
    if cyclic:
        into = (g - opens) % 1.0
        inside = into < close
    else:
        into = g - opens
        inside = (into >= 0.0) & ((into < close) | (opens + close >= 1.0 - 1e-9))
    rolls = close - heel > FLAT_TO_THE_END  # else a foot that does not roll off: flat while held
    return inside, np.where(rolls, _smoothstep((into - heel) / np.where(rolls, close - heel, 1.0)), np.where(inside, 0.0, 1.0))


def swing_lifts(cyclic: bool, g: np.ndarray, opens: np.ndarray, times: np.ndarray) -> np.ndarray:
    """How much of ``SWING_LIFT`` a free foot keeps under it at generic times ``g (..., 1)``: ``(..., L)``, 1 from
    toe-off (and while its hold is open, for a foot let go early), fading to 0 by smoothstep over the last
    ``SWING_LANDING`` of the swing, so the foot lands where the verb lands it. A one-shot verb's feet get none:
    their swings have no next landing to come down for."""
    shape = np.broadcast_shapes(np.shape(g), np.shape(times)[:-1])
    if not cyclic:
        return np.zeros(shape)
    close = times[..., 2] - opens
    into = (g - opens) % 1.0
    swung = (into - close) / np.where(close < 1.0, 1.0 - close, 1.0)
    lift = _smoothstep((1.0 - swung) / SWING_LANDING)
    return np.broadcast_to(np.where((into < close) | (close >= 1.0), 1.0, lift), shape)


def example_lifts(verb: Verb, weights: np.ndarray, g: np.ndarray) -> np.ndarray:
    """How high the examples lift each foot at generic times ``g (C,)`` (``g`` below 0: the cycle before, shifted by
    its seam, as a verb's loop plays it; 1 or more: the cycle after), blended by cardinal ``weights (C, E)`` (or
    ``(C, W)``: the first E are the examples'): ``(C, L)`` metres over each effector's contact height, held within
    the lowest and highest of the examples there; ``-inf`` (none) for a one-shot verb (its swings have no next
    landing) and an effector that keeps the verb's height.

    The planter keeps a swinging foot no lower than this: a blend of the examples' leg rotations can put the foot
    lower than any of them does (the CMU run at 3.6 m/s turning 30°/s brought its toes in 3 cm under every
    example's and skidded them 35 cm along the floor). At an example, its own lift, which the foot has already
    (:attr:`Verb.lift_table`, linearly between its samples)."""
    c, n_l = len(g), len(verb.holds)
    if not verb.cyclic or not n_l:
        return np.full((c, n_l), -np.inf)
    g = np.asarray(g, dtype=float)
    table = verb.lift_table  # (3, E, S + 1, L): laps -1, 0, 1
    s = table.shape[2] - 1
    lap = np.floor(g)
    x = (g - lap) * s
    k = np.minimum(np.floor(x).astype(np.int64), s - 1)
    f = (x - k)[:, None, None]
    row = np.clip(lap, -1, 1).astype(np.int64) + 1  # the cycle before, this one, the one after
    at = table[row, :, k] * (1.0 - f) + table[row, :, k + 1] * f  # (C, E, L)
    w = np.asarray(weights, dtype=float)[:, : table.shape[1]]
    out = np.zeros((c, n_l))
    for e in range(table.shape[1]):  # summed in the kernel's order: the same bits
        out += w[:, e, None] * at[:, e]
    out = np.clip(out, at.min(axis=1), at.max(axis=1))
    return np.where(np.isnan(out), -np.inf, out)


def _ramp(x: np.ndarray, k: float) -> np.ndarray:
    """``max(x, 0)``, rounded over its first ``k`` (``x²/2k``, then ``x − k/2``): 0 at and below 0, its slope never
    jumping."""
    x = np.maximum(x, 0.0)
    return np.where(x < k, x * x / (2.0 * k), x - 0.5 * k)


def _lowered(lift: np.ndarray, hover: np.ndarray) -> np.ndarray:
    """A free foot's height above its contact height: the verb's ``lift``, less its ``hover`` (the verb's own
    contact level at these adverbs) near that level, fading to none ``SWING_CLEARANCE`` above it, so the
    foot lands on the floor and swings as high as the verb swings it."""
    return lift - hover * (1.0 - _smoothstep((lift - hover) / SWING_CLEARANCE))


def _smooth_max(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    """``max(a, b)``, rounded where the two are within ``k`` of each other (``+ k h²/4``, ``h = 1 − |a − b|/k``), so
    its slope does not jump where one overtakes the other."""
    h = np.maximum(k - np.abs(a - b), 0.0) / k
    return np.maximum(a, b) + 0.25 * k * h * h


def _smoothstep(x: np.ndarray) -> np.ndarray:
    """``3x² − 2x³`` of ``x`` clipped to ``[0, 1]``: from 0 to 1 with zero slope at both ends."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _turn(held: np.ndarray, free: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Rotations ``(..., 3, 3)`` turned from ``held`` to ``free`` by weights ``w (...)`` (slerp; only where
    ``0 < w < 1``, the rest is one or the other)."""
    w = np.broadcast_to(w, np.broadcast_shapes(held.shape[:-2], free.shape[:-2], np.shape(w)))
    out = np.where((w >= 1.0)[..., None, None], free, held)
    part = (w > 0.0) & (w < 1.0)
    if part.any():
        a, b = np.broadcast_to(held, out.shape)[part], np.broadcast_to(free, out.shape)[part]
        out[part] = quat.to_matrix(quat.slerp(quat.from_matrix(a), quat.from_matrix(b), w[part]))
    return out


def _heel_turn(wanted: np.ndarray, axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Foot orientations ``wanted (..., L, 3, 3)`` turned heel-up by ``angle (..., L)`` about ``axis (L, 3)`` in the
    foot's frame (``LegChains.heel_axis``; turning about it leaves it where it is, so the lifted foot gives the
    axis back)."""
    if not np.any(angle):
        return wanted
    world = np.einsum("...ij,...j->...i", wanted, axis)
    return quat.rotvec_matrix(world * angle[..., None]) @ wanted


def _heel_needed(to_ball: np.ndarray, arm: np.ndarray, axis: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """The least heel lift ``(..., L)`` in ``[0, π]`` that brings the ankle within ``reach (L,)`` of the hip, for a
    ball ``to_ball (..., L, 3)`` from the hip and ankle ``arm`` from the ball, turning about ``axis``; where no
    lift brings it within reach, the lift that brings it closest; 0 where it is within reach or lifting
    does not bring it closer.

    The hip-to-ankle distance is ``|to_ball + arm(θ)|`` with ``arm(θ) = a∥ + a⊥ cos θ + (axis × arm) sin θ``, so
    its square is ``K + 2 (A cos θ + B sin θ)``: the first ``θ`` where that falls to ``reach²`` is closed-form.
    """
    along = np.sum(arm * axis, axis=-1, keepdims=True) * axis
    a = np.sum(to_ball * (arm - along), axis=-1)
    b = np.sum(to_ball * np.cross(axis, arm), axis=-1)
    c = np.sum(to_ball * along, axis=-1)
    room = 0.5 * (reach**2 - np.sum(to_ball**2, axis=-1) - np.sum(arm**2, axis=-1)) - c  # A cos θ + B sin θ ≤ room
    r = np.hypot(a, b)
    start = np.arctan2(-b, a)  # θ = 0 is at this angle past the sinusoid's peak (in (0, π) when lifting helps)
    cross = np.arccos(np.clip(room / np.where(r > 0.0, r, 1.0), -1.0, 1.0))
    return np.where((a > room) & (b < 0.0), np.maximum(cross - start, 0.0), 0.0)


def _rise(verb: Verb, floor: Floor, root: np.ndarray, feet: np.ndarray) -> np.ndarray:
    """How far the pelvis rides up: the floor's height under the body root ``root (..., 3)``, or under the lower
    foot (``feet (..., L, 3)``, the effectors' targets) where that is lower, so up a slope the body stays low
    enough for the trailing leg to reach its foot; relative to the verb's own floor."""
    return np.minimum(floor.height(root[..., [0, 2]]), floor.height(feet[..., [0, 2]]).min(axis=-1)) - verb.floor


def _ride_floor(verb: Verb, chains: ik.LegChains, translations, grot, rise) -> np.ndarray:
    """Translations with the pelvis raised along world up by ``rise (...,)``."""
    t = np.array(translations, dtype=float)
    lift = chains.above[-1]
    up = np.broadcast_to([0.0, 1.0, 0.0], rise.shape + (3,))
    parent = verb.skeleton.parents[lift]
    if parent >= 0:
        up = quat.rotate(quat.inv(grot[..., parent, :]), up)
    t[..., lift, :] += rise[..., None] * up
    return t


def frame_generic(verb: Verb, keytimes: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Generic time of clock times ``times (...)`` of motions of ``verb`` with ``keytimes (..., N)``: the frames
    of one motion (``(F,)`` with ``(N,)``), or each creature of a crowd (``(C,)`` with ``(C, N)``)."""
    k = np.asarray(keytimes, dtype=float)
    t = np.asarray(times, dtype=float)
    t = t % k[..., -1] if verb.cyclic else np.clip(t, 0.0, k[..., -1])
    g = timewarp.generic_time(t, k, verb.generic_keytimes)
    if not verb.cyclic:
        g = np.where(np.asarray(times) >= k[..., -1] - 1e-9, 1.0, g)
    return g


def effector_joints(verb: Verb) -> list[int]:
    """Joint index of each constraint's effector."""
    return [verb.skeleton.index(c.effector) for c in verb.constraints]
