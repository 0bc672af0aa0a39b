"""What planted feet did, measured on the frames written: drift of held feet, heel drift while flat, the lowest
toe against the floor, how high a held toe sits, slides after release (:func:`measure_feet`), and the drift of a
verb's own contact phases (:func:`foot_drift`, :func:`planted_drift`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..kinematics.floor import FlatFloor, Floor
from ..motion.clip import Clip
from .offline import PlantingReport, phase_frames
from .planter import LIFTED, effector_joints
from ..verb.tables import Verb

def planted_drift(positions: np.ndarray, spans: list[tuple[int, int]]) -> np.ndarray:
    """Per contact phase ``[start, stop)``: the largest horizontal distance from where it began, ``(P,)`` metres."""
    out = []
    for a, b in spans:
        xz = positions[a:b][:, [0, 2]]
        out.append(float(np.linalg.norm(xz - xz[0], axis=-1).max()) if len(xz) else 0.0)
    return np.array(out)


def foot_drift(verb: Verb, clip: Clip, keytimes: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """:func:`planted_drift` of every constrained effector of ``clip`` over the phases the examples' contact
    times give (:func:`phase_frames`; a planted clip's own are in its report), all together, metres."""
    gpos = clip.global_positions()
    spans = phase_frames(verb, keytimes, clip, weights)
    return np.concatenate([planted_drift(gpos[:, e], s) for e, s in zip(effector_joints(verb), spans)] or [np.zeros(0)])


@dataclass
class FootMetrics:
    """What planted feet look like, measured on the output's joints (metres, m/s); see :func:`measure_feet`.

    ``toe_drift (P,)``: per held phase of the ball, its largest horizontal distance from where the phase
    began. ``heel_drift (Q,)``: the same for the ankle over each phase where the foot is flat.
    ``lowest``: the lowest any constrained effector gets, against the floor plus its contact height
    (negative: through the floor). ``held_height``: the largest distance of a held ball from the floor
    plus its contact height while the foot is flat (rolling off, it rises with the verb's). ``slide (R,)``: per release, how far the foot moves horizontally before it
    rises ``LIFTED`` above its contact height, on its way up (``free_slide``: the same for the verb's own
    motion, if given). ``release_speed (R,)``: the foot's largest speed over the
    three frames after each release. ``unreachable``: effector-frames the IK could not reach.
    """

    toe_drift: np.ndarray
    heel_drift: np.ndarray
    lowest: float
    held_height: float
    slide: np.ndarray
    release_speed: np.ndarray
    unreachable: int
    free_slide: np.ndarray = field(default_factory=lambda: np.zeros(0))
    aloft: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (L,) each foot's lowest, over its contact height
    feet: tuple[str, ...] = ()  # the constrained effectors' names, in the order of ``aloft``

    def line(self) -> str:
        """One line for a terminal."""
        def mm(x: np.ndarray, f=np.max) -> str:
            return f"{1000 * f(x):.1f}" if len(x) else "-"

        never = [f"{n} {1000 * a:.0f} mm" for n, a in zip(self.feet, self.aloft) if a > LIFTED]
        return (
            f"toe drift median {mm(self.toe_drift, np.median)} / max {mm(self.toe_drift)} mm, heel drift max "
            f"{mm(self.heel_drift)} mm, lowest {1000 * self.lowest:+.1f} mm, held height within "
            f"{1000 * self.held_height:.1f} mm, slide after release max {mm(self.slide)} mm, "
            f"{self.unreachable} effector-frames out of reach"
            + (f"; feet never down (lowest over the contact height): {', '.join(never)}" if never else "")
        )


def measure_feet(
    verb: Verb, planted: Clip, report: PlantingReport, floor: Floor | None = None, free: Clip | None = None
) -> FootMetrics:
    """:class:`FootMetrics` of ``planted`` (what :func:`plant_feet` returned with ``report``) on ``floor``.

    With ``free``, the verb's own motion that was planted, ``free_slide`` measures its toe the same way
    against its own contact level (the lowest it was over the hold before): the slide the verb itself
    has (a foot that sweeps the ground in a pivot turn).
    """
    floor = FlatFloor(verb.floor) if floor is None else floor
    gpos = planted.global_positions()
    tips = effector_joints(verb)
    toe, ankle = gpos[:, tips], gpos[:, verb.leg_chains.end]
    height = np.array([0.0 if h.height is None else h.height for h in verb.holds])
    follows = np.array([h.height is None for h in verb.holds])
    above = toe[..., 1] - floor.height(toe[..., [0, 2]]) - height
    speed = np.zeros(toe.shape[:2])
    speed[1:] = np.linalg.norm(np.diff(toe, axis=0), axis=-1) * planted.fps
    releases = [(i, a, b) for i in range(len(tips)) for a, b in report.phases[i] if b < planted.num_frames]
    held = [np.abs(above[a:b, i]).max() for i in range(len(tips)) if not follows[i] for a, b in report.flat[i]]
    free_slide = np.zeros(0)
    if free is not None:
        ftoe = free.global_positions()[:, tips]
        lift = ftoe[..., 1] - verb.floor - height
        # Against the verb's own contact level: the lowest its toe was over the hold before each release.
        own = np.full(lift.shape, np.inf)
        for i, a, b in releases:
            nxt = min([s for s, _ in report.phases[i] if s > a] or [len(ftoe)])
            own[b:nxt, i] = lift[b:nxt, i] - lift[a:b, i].min()
        free_slide = _slides(ftoe, own, releases, report.phases)
    return FootMetrics(
        np.concatenate([planted_drift(toe[:, i], report.phases[i]) for i in range(len(tips))]),
        np.concatenate([planted_drift(ankle[:, i], report.flat[i]) for i in range(len(tips))]),
        float(np.where(follows, np.inf, above).min()) if not follows.all() else 0.0,
        float(max(held, default=0.0)),
        _slides(toe, above, releases, report.phases),
        np.array([speed[b : b + 3, i].max() for i, _, b in releases]),
        report.unreachable,
        free_slide,
        # Measured on the frames, whatever the planter held: a foot the verb puts down that never comes near the ground.
        np.array([0.0 if follows[i] else max(float(above[:, i].min()), 0.0) for i in range(len(tips))]),
        tuple(verb.skeleton.names[j] for j in tips),
    )


def _slides(toe: np.ndarray, above: np.ndarray, releases: list, phases: list) -> np.ndarray:
    """Per release ``(leg, start, stop)``: how far the toe travels horizontally before it has left the ground on its
    way up: from its last held frame until it is first ``LIFTED`` above its contact height (``above (F, L)``), and
    no further than the swing's highest point (before the next hold). So a foot that drags before it lifts
    counts, and neither a landing nor a swing that later passes low again (a cycle's seam) does."""
    out = []
    for i, a, b in releases:
        nxt = min([s for s, _ in phases[i] if s > a] or [len(toe)])
        swing = above[b : max(nxt, b + 1), i]
        apex = int(np.argmax(swing))
        lifted = np.flatnonzero(swing >= LIFTED)
        stop = b + (min(int(lifted[0]), apex + 1) if len(lifted) else apex + 1)
        out.append(float(np.linalg.norm(np.diff(toe[b - 1 : stop, i][:, [0, 2]], axis=0), axis=-1).sum()))
    return np.array(out)
