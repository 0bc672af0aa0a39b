"""A scripted performance through a verb graph, recorded: what ``adverbs graph --play`` writes and tests measure.

:func:`perform` runs :func:`~adverbs.graph.player.step` and the graph's foot planter frame by frame for one
creature, following a script of timed commands (a verb to perform, or adverbs to change), and records
the motion before and after planting, what was playing at every frame, and how planting went.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import AdverbsError
from ..kinematics.floor import FlatFloor, Floor
from ..motion.clip import Clip
from ..motion.contacts import runs
from ..verb.planting import PlantingReport, mode_masks
from .player import GraphState, command, new_state, plant, planter, step
from .structure import CommandRefused, Graph

MAX_SECONDS = 3600.0


@dataclass
class Cue:
    """At ``time`` seconds: perform ``verb`` (when given) and set ``adverbs`` (when given)."""

    time: float
    verb: str | None = None
    adverbs: dict[str, float] | None = None


@dataclass
class Performance:
    """One creature's recorded performance: the ``planted`` clip and the ``free`` one (before planting), what
    played at every frame (``playing``: words; ``active (F,)``: the transition under way, −1 none; ``verb
    (F,)``), the planting ``report``, the commands ``refused`` (time, reason) and the final ``state``."""

    planted: Clip
    free: Clip
    playing: list[str]
    active: np.ndarray
    verb: np.ndarray
    report: PlantingReport
    refused: list[tuple[float, str]]
    state: GraphState


def perform(
    graph: Graph,
    script: Sequence[Cue] = (),
    seconds: float = 10.0,
    fps: float = 30.0,
    seed: int = 0,
    floor: Floor | None = None,
    start: str | None = None,
    adverbs: dict[str, float] | None = None,
    root: Sequence[float] = (0.0, 0.0, 0.0),
) -> Performance:
    """Play ``seconds`` of one creature through ``graph`` at ``fps``, following ``script``; plant its feet on ``floor``.

    A cue whose command is refused (an unknown or unreachable verb, a bad adverb) is recorded in
    :attr:`Performance.refused` and the creature carries on.
    """
    if not (np.isfinite(seconds) and 0 < seconds <= MAX_SECONDS):
        raise AdverbsError(f"seconds must be a number in (0, {MAX_SECONDS:g}], got {seconds}")
    if not (np.isfinite(fps) and 1 <= fps <= 1000):
        raise AdverbsError(f"fps must be a number from 1 to 1000, got {fps}")
    floor = FlatFloor(0.0) if floor is None else floor
    state = new_state(graph, 1, seed, start, graph.point(adverbs)[None], np.asarray(root, dtype=float)[None])
    feet = planter(graph, 1, floor) if any(v.holds for v in graph.verbs) else None
    cues = sorted(script, key=lambda c: c.time)
    frames = int(round(seconds * fps))
    dt = 1.0 / fps
    j = graph.skeleton.num_joints
    rot, trans = np.empty((frames, j, 4)), np.empty((frames, j, 3))
    free_rot, free_trans = np.empty((frames, j, 4)), np.empty((frames, j, 3))
    playing, active, verb = [], np.empty(frames, dtype=np.int64), np.empty(frames, dtype=np.int64)
    legs = len(feet.tips) if feet is not None else 0
    modes, turns, drops = np.zeros((frames, legs), dtype=np.int64), np.zeros((frames, legs)), np.zeros(frames)
    refused: list[tuple[float, str]] = []
    unreachable = 0
    k = 0
    for f in range(frames):
        now = f * dt
        while k < len(cues) and cues[k].time <= now + 1e-9:
            cue = cues[k]
            k += 1
            try:
                if cue.adverbs:
                    p = graph.point({**dict(zip(graph.adverb_names, state.points[0])), **cue.adverbs})
                    state.points[0] = p
                if cue.verb is not None:
                    command(state, 0, cue.verb)
            except (CommandRefused, AdverbsError) as e:
                refused.append((cue.time, str(e)))
        frame = step(state, dt)
        free_rot[f], free_trans[f] = frame.rotations[0], frame.translations[0]
        if feet is not None:
            r, t, result = plant(feet, frame, dt, state.alone)
            rot[f], trans[f] = r[0], t[0]
            modes[f], turns[f] = feet.mode[0], feet.turn[0]
            drops[f] = result.root_drop[0]
            unreachable += int(np.count_nonzero(result.unreachable))
        else:
            rot[f], trans[f] = free_rot[f], free_trans[f]
        playing.append(state.playing(0))
        active[f], verb[f] = state.active[0], state.verb[0]
    held, flat, heel = mode_masks(modes, turns)
    report = PlantingReport(
        [runs(held[:, i]) for i in range(legs)], drops, unreachable, [],
        [runs(flat[:, i]) for i in range(legs)], [runs(heel[:, i]) for i in range(legs)],
    )  # fmt: skip
    name = graph.name
    planted = Clip(graph.skeleton, rot, trans, fps, name=name)
    free = Clip(graph.skeleton, free_rot, free_trans, fps, name=name)
    return Performance(planted, free, playing, active, verb, report, refused, state)
