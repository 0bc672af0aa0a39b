"""Offline planting: every frame of whole clips through the foot planter (:mod:`.planter`), then one batched IK
solve, and what the planter held (:class:`PlantingReport`: hold phases per foot, root drop, targets out of reach).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import AdverbsError
from ..interp import timewarp
from ..kinematics import ik, quat
from ..kinematics.floor import FlatFloor, Floor
from ..motion.clip import Clip
from ..motion.contacts import runs
from .planter import BALL, FREE, FootPlanter, _ride_floor, _rise, frame_generic, hold_modes
from ..verb.tables import Verb

@dataclass
class PlantingReport:
    """What planting did: hold phases per effector (frames ``[start, stop)``), and what it could not do."""

    phases: list[list[tuple[int, int]]]
    root_drop: np.ndarray  # (F,) metres
    unreachable: int  # frames × effectors whose target stayed out of reach
    warnings: list[str] = field(default_factory=list)
    flat: list[list[tuple[int, int]]] = field(default_factory=list)  # heel and ball held (foot flat)
    heel: list[list[tuple[int, int]]] = field(default_factory=list)  # heel held (heel strike to heel-off)



def phase_masks(
    verb: Verb, keytimes: np.ndarray, clip: Clip, weights: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where each effector itself is held (foot flat to toe-off), where its foot is flat (heel and ball
    held: foot flat to heel-off) and where its heel is held (heel strike to heel-off), as the examples'
    contact times say: masks ``(F, L)`` over the frames of ``clip``, a motion of ``verb`` with
    ``keytimes`` at cardinal ``weights (E,)`` (default: the holds' mean times). (The planter lands the
    ball when it reaches the floor; what it did is in its :class:`PlantingReport`.)"""
    g = frame_generic(verb, keytimes, np.arange(clip.num_frames) / clip.fps)
    opens = np.array([h.open for h in verb.holds])
    times = verb.hold_times(weights) if weights is not None else np.array([h.times for h in verb.holds])
    inside, turn = hold_modes(verb.cyclic, g[:, None], opens, times)
    into = (g[:, None] - opens) % 1.0 if verb.cyclic else g[:, None] - opens
    ball = inside & (into >= times[..., 0] - opens)
    return ball, ball & (turn == 0.0), inside & (turn == 0.0)


def mode_masks(modes: np.ndarray, turns: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ball held, foot flat and heel held ``(F, L)`` from the planter's modes and turn-back weights."""
    ball = modes == BALL
    return ball, ball & (turns == 0.0), (modes != FREE) & (turns == 0.0)


def report_of_modes(
    modes: np.ndarray, turns: np.ndarray, root_drop: np.ndarray, unreachable: int = 0, miss: float = 0.0
) -> PlantingReport:
    """The :class:`PlantingReport` of the planter's modes and turn-back weights ``(F, L)`` frame by frame: its
    phases, the ``root_drop (F,)`` and, with ``unreachable`` effector-frames, the warning naming the largest
    ``miss`` (metres)."""
    held, flat, heel = mode_masks(modes, turns)
    legs = range(modes.shape[1])
    warnings = [
        f"{unreachable} effector-frames could not reach their targets (largest miss {1000 * miss:.0f} mm); "
        "the pose was left as close as it gets"
    ] if unreachable else []  # fmt: skip
    return PlantingReport(
        [runs(held[:, i]) for i in legs], root_drop, unreachable, warnings, [runs(flat[:, i]) for i in legs],
        [runs(heel[:, i]) for i in legs],
    )  # fmt: skip


def phase_frames(
    verb: Verb, keytimes: np.ndarray, clip: Clip, weights: np.ndarray | None = None
) -> list[list[tuple[int, int]]]:
    """Each effector's held phases in frames ``[start, stop)`` of ``clip`` (a motion of ``verb`` with ``keytimes``)."""
    held = phase_masks(verb, keytimes, clip, weights)[0]
    return [runs(held[:, i]) for i in range(held.shape[1])]


def plant_feet(
    verb: Verb, clip: Clip, keytimes: np.ndarray, floor: Floor | None = None, point: np.ndarray | None = None
) -> tuple[Clip, PlantingReport]:
    """Enforce ``verb``'s constraints on ``clip`` (synthesized by it at adverb ``point`` with ``keytimes``) on ``floor``.

    The :class:`FootPlanter` run over the frames in order, then every frame's legs in one batched IK
    solve: the same motion as planting one frame at a time. ``point`` sets when each foot lands and
    lifts (the examples' own contact times, blended); without it, their mean.
    """
    return plant_feet_many(verb, [(clip, keytimes, point)], floor)[0]


def _checked_motion(verb: Verb, i: int, motion) -> tuple[Clip, np.ndarray, np.ndarray | None]:
    """Motion ``i`` as ``(clip, keytimes, point)``, refused unless it can be a motion of ``verb``: its clip on the
    verb's skeleton, its keytimes as many as the verb's, from 0 and in order, its point one of the verb's."""
    if not isinstance(motion, tuple | list) or len(motion) not in (2, 3) or not isinstance(motion[0], Clip):
        raise AdverbsError(f"motion {i}: give (clip, keytimes) or (clip, keytimes, point), got {type(motion).__name__}")
    clip, keytimes, point = motion[0], motion[1], motion[2] if len(motion) > 2 else None
    what = f"motion {i} (clip {clip.name!r})"
    why = verb.skeleton.structure_difference(clip.skeleton)
    if why is not None:
        raise AdverbsError(f"{what} is not on the skeleton of verb {verb.name!r}: {why}")
    k = timewarp.check_keytimes(keytimes, f"{what}: keytimes")
    if k.shape != verb.generic_keytimes.shape or k[0] < 0:
        raise AdverbsError(
            f"{what}: keytimes must be {len(verb.generic_keytimes)} times in seconds from 0 (as synthesize returns "
            f"them), got shape {k.shape} from {k.flat[0]:g}"
        )
    return clip, k, None if point is None else verb.point(point)


def plant_feet_many(
    verb: Verb, motions: Sequence[tuple], floor: Floor | None = None
) -> list[tuple[Clip, PlantingReport]]:
    """:func:`plant_feet` for many creatures' motions of one verb, ``(clip, keytimes)`` or ``(clip, keytimes,
    point)`` each (their own adverbs, keytimes and length): every frame of every creature goes through
    one batched IK solve.
    """
    floor = FlatFloor(verb.floor) if floor is None else floor
    motions = [_checked_motion(verb, i, m) for i, m in enumerate(motions)]
    if not verb.constraints:
        return [(clip, PlantingReport([], np.zeros(clip.num_frames), 0)) for clip, _, _ in motions]
    # Every creature's planter state advanced together, frame by frame (shorter clips repeat their last
    # frame; what comes after their end is dropped): the state machine is vectorized over creatures.
    c, longest = len(motions), max(clip.num_frames for clip, _, _ in motions)
    weights = np.stack([verb.weights(verb.point(p)) if p is not None else np.full(len(verb.examples), np.nan)
                        for _, _, p in motions])  # fmt: skip
    planter = FootPlanter(verb, c, floor)
    known = ~np.isnan(weights[:, 0])
    if known.any():
        planter.times[known] = verb.hold_times(weights[known])
    fk = [clip.forward_kinematics() for clip, _, _ in motions]
    tips, ends = planter.tips, planter.chains.end
    free_pos = np.empty((longest, c, len(tips), 3))
    free_rot = np.empty((longest, c, len(tips), 3, 3))
    g = np.empty((longest, c))
    for i, ((clip, keytimes, _), (gpos, grot)) in enumerate(zip(motions, fk)):
        n = clip.num_frames
        free_pos[:n, i], free_rot[:n, i] = gpos[:, tips], quat.to_matrix(grot[:, ends])
        free_pos[n:, i], free_rot[n:, i] = free_pos[n - 1, i], free_rot[n - 1, i]
        g[:n, i] = frame_generic(verb, keytimes, np.arange(n) / clip.fps)
        g[n:, i] = g[n - 1, i]
    dt = np.array([1.0 / clip.fps for clip, _, _ in motions])
    tg, wanted = np.empty_like(free_pos), np.empty_like(free_rot)
    modes, turns = np.empty(free_pos.shape[:3], dtype=int), np.empty(free_pos.shape[:3])
    roots = np.empty((longest, c, 3))
    hips = np.empty((longest, c, len(tips), 3))
    for i, ((clip, _, _), (gpos, _)) in enumerate(zip(motions, fk)):
        n = clip.num_frames
        roots[:n, i], hips[:n, i] = gpos[:, verb.encoding.body_root], gpos[:, planter.chains.upper]
        roots[n:, i], hips[n:, i] = roots[n - 1, i], hips[n - 1, i]
    rises, drops = np.empty((longest, c)), np.empty((longest, c))
    for f in range(longest):
        tg[f], wanted[f] = planter.targets(free_pos[f], free_rot[f], g[f], dt)
        rises[f] = _rise(verb, floor, roots[f], tg[f])
        tg[f], wanted[f], drops[f] = planter.reach(hips[f], rises[f], tg[f], wanted[f], dt)
        modes[f], turns[f] = planter.shown_mode, planter.rolled
    rots, trans, targets, tilts, starts, min_drops = [], [], [], [], [0], []
    for i, ((clip, _, _), (_, grot)) in enumerate(zip(motions, fk)):
        n = clip.num_frames
        rots.append(clip.rotations)
        trans.append(_ride_floor(verb, planter.chains, clip.translations, grot, rises[:n, i]))
        targets.append(tg[:n, i])
        tilts.append(planter._tilts(wanted[:n, i], free_rot[:n, i]))
        min_drops.append(drops[:n, i])
        starts.append(starts[-1] + n)
    result = ik.solve(
        verb.leg_chains, np.concatenate(rots), np.concatenate(trans), np.concatenate(targets), np.concatenate(tilts),
        min_drop=np.concatenate(min_drops),
    )  # fmt: skip
    out = []
    for i, ((clip, _, _), a, b) in enumerate(zip(motions, starts[:-1], starts[1:])):
        n = clip.num_frames
        unreachable = int(np.count_nonzero(result.unreachable[a:b]))
        planted = clip.replace(rotations=result.rotations[a:b], translations=result.translations[a:b])
        report = report_of_modes(
            modes[:n, i], turns[:n, i], result.root_drop[a:b], unreachable, float(result.residual[a:b].max(initial=0.0))
        )
        out.append((planted, report))
    return out
