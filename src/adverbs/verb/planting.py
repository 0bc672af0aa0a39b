"""Planted feet: a verb's constraints enforced on its synthesized motion (§3.3).

When a constraint's opening keytime is crossed, its target is set from where the verb puts the
effector: its horizontal position then. Until the closing keytime the effector is held there; after
it, the hold is released over ``release`` seconds (smoothstep), so nothing pops. Heights follow the
floor: a point the verb carries ``h`` above its own flat ground is put ``h`` above the floor under it,
and the root follows the floor under itself, so a walk goes up and down a slope; on a floor that is
not flat each foot is also tilted to the surface. Every frame, :func:`adverbs.kinematics.ik.solve` moves the
legs (and lowers the root when a target is out of reach); nothing else changes.

:func:`planted_drift` is the measure shared by tests, benchmarks and ``adverbs evaluate``: per contact
phase, the largest horizontal distance of the planted effector from where the phase began.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..kinematics import ik, quat
from ..kinematics.floor import FlatFloor, Floor, tilt
from ..motion.clip import Clip
from .constraints import phases
from .tables import Verb

RELEASE = 1.0  # seconds: the longest a closed constraint takes to let go (it is done by the next landing)


@dataclass
class PlantingReport:
    """What planting did: contact phases per constraint (frames ``[start, stop)``) and what it could not do."""

    phases: list[list[tuple[int, int]]]
    root_drop: np.ndarray  # (F,) metres
    unreachable: int  # frames × effectors whose target stayed out of reach
    warnings: list[str] = field(default_factory=list)


def phase_frames(verb: Verb, keytimes: np.ndarray, clip: Clip) -> list[list[tuple[int, int]]]:
    """Each constraint's contact phases in frames of ``clip`` (a motion of ``verb`` with ``keytimes``)."""
    out = []
    for c in verb.constraints:
        spans = phases(c, keytimes, clip.duration + 0.5 / clip.fps, verb.cyclic)
        frames = []
        for a, b in spans:
            fa = int(np.ceil(a * clip.fps - 1e-6))
            fb = min(int(np.ceil(b * clip.fps - 1e-6)), clip.num_frames)
            if fb > fa:
                frames.append((fa, fb))
        out.append(frames)
    return out


def plant_feet(
    verb: Verb, clip: Clip, keytimes: np.ndarray, floor: Floor | None = None, release: float = RELEASE
) -> tuple[Clip, PlantingReport]:
    """Enforce ``verb``'s constraints on ``clip`` (synthesized by it with ``keytimes``) on ``floor``.

    Every frame is solved in one batched call. A released foot goes back to the verb's motion in
    joint space: its chain's rotations turn (slerp, smoothstep weight) from the last held
    configuration to the free one over the swing, and a root drop the hold needed fades out the
    same way, so no joint speeds up where a constraint closes.
    """
    return plant_feet_many(verb, [(clip, keytimes)], floor, release)[0]


def plant_feet_many(
    verb: Verb,
    motions: Sequence[tuple[Clip, np.ndarray]],
    floor: Floor | None = None,
    release: float = RELEASE,
) -> list[tuple[Clip, PlantingReport]]:
    """:func:`plant_feet` for many creatures' motions of one verb (each with its own adverbs, keytimes
    and length): every frame of every creature goes through the same two batched IK solves.
    """
    floor = FlatFloor(verb.floor) if floor is None else floor
    if not verb.constraints:
        return [(clip, PlantingReport([], np.zeros(clip.num_frames), 0)) for clip, _ in motions]
    chains = verb.leg_chains
    tips = effector_joints(verb)
    held, trans, spans, releases, starts = [], [], [], [], [0]
    for clip, keytimes in motions:
        f, o = clip.num_frames, starts[-1]
        gpos, grot = clip.forward_kinematics()
        phases_c = phase_frames(verb, keytimes, clip)
        time = np.arange(f) / clip.fps
        target = np.empty((f, len(tips), 3))  # where each effector goes: held in its phases, on the floor
        for i, (tip, frames) in enumerate(zip(tips, phases_c)):
            xz = gpos[:, tip][:, [0, 2]].copy()
            for n, (a, b) in enumerate(frames):
                xz[a:b] = xz[a]
                # Released over the swing, until the next landing (or ``release`` seconds): the weights
                # follow that whole span even where the clip ends first, so the last frames do not jump.
                span = min(frames[n + 1][0] if n + 1 < len(frames) else b + release * clip.fps, b + release * clip.fps)
                until = min(int(np.ceil(span)), f)
                if until > b:
                    s = (time[b:until] - time[b - 1]) / ((span - (b - 1)) / clip.fps)
                    releases.append((i, o + b, o + until, s * s * (3.0 - 2.0 * s)))
            target[:, i, [0, 2]] = xz
            target[:, i, 1] = floor.height(xz) + (gpos[:, tip, 1] - verb.floor)
        # The pelvis rides the floor under it: raised along world up, in its parent's frame.
        t = clip.translations.copy()
        lift = chains.above[-1]
        rise = floor.height(gpos[:, verb.encoding.body_root][:, [0, 2]]) - verb.floor
        up = np.broadcast_to([0.0, 1.0, 0.0], (f, 3))
        parent = verb.skeleton.parents[lift]
        if parent >= 0:
            up = quat.rotate(quat.inv(grot[:, parent]), up)
        t[:, lift] += rise[:, None] * up
        held.append(target)
        trans.append(t)
        spans.append(phases_c)
        starts.append(o + f)

    rotations = np.concatenate([clip.rotations for clip, _ in motions])
    translations = np.concatenate(trans)
    targets = np.concatenate(held)
    tilts = None if floor.is_flat else tilt(floor.normal(targets[..., [0, 2]]))
    first = ik.solve(chains, rotations, translations, targets, tilts)
    # A drop the hold needed fades out over the release instead of ending at once.
    min_drop = first.root_drop.copy()
    for _, b, until, w in releases:
        min_drop[b:until] = np.maximum(min_drop[b:until], (1.0 - w) * first.root_drop[b - 1])
    result = ik.solve(chains, rotations, translations, targets, tilts, min_drop=min_drop)
    rotations = result.rotations
    for i, b, until, w in releases:
        joints = [chains.upper[i], chains.middle[i], chains.end[i]]
        start = np.broadcast_to(rotations[b - 1, joints], (until - b, len(joints), 4))
        rotations[b:until, joints] = quat.slerp(start, rotations[b:until, joints], w[:, None])

    out = []
    for (clip, _), phases_c, a, b in zip(motions, spans, starts[:-1], starts[1:]):
        unreachable = int(np.count_nonzero(result.unreachable[a:b]))
        warnings = []
        if unreachable:
            warnings.append(
                f"{unreachable} effector-frames could not reach their targets (largest miss "
                f"{1000 * result.residual[a:b].max():.0f} mm); the pose was left as close as it gets"
            )
        planted = clip.replace(rotations=rotations[a:b], translations=result.translations[a:b])
        out.append((planted, PlantingReport(phases_c, result.root_drop[a:b], unreachable, warnings)))
    return out


def planted_drift(positions: np.ndarray, spans: list[tuple[int, int]]) -> np.ndarray:
    """Per contact phase ``[start, stop)``: the largest horizontal distance from where it began, ``(P,)`` metres."""
    out = []
    for a, b in spans:
        xz = positions[a:b][:, [0, 2]]
        out.append(float(np.linalg.norm(xz - xz[0], axis=-1).max()) if len(xz) else 0.0)
    return np.array(out)


def foot_drift(verb: Verb, clip: Clip, keytimes: np.ndarray) -> np.ndarray:
    """:func:`planted_drift` of every constrained effector of ``clip``, all phases together, metres."""
    gpos = clip.global_positions()
    spans = phase_frames(verb, keytimes, clip)
    return np.concatenate([planted_drift(gpos[:, e], s) for e, s in zip(effector_joints(verb), spans)] or [np.zeros(0)])


def effector_joints(verb: Verb) -> list[int]:
    """Joint index of each constraint's effector."""
    return [verb.skeleton.index(c.effector) for c in verb.constraints]
