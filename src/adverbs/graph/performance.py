"""A scripted performance through a verb graph, recorded: what ``adverbs graph --play`` writes and tests measure.

:func:`perform` runs :func:`~adverbs.graph.player.step` and the graph's foot planter frame by frame for one
creature, following a script of timed commands (a verb to perform, or adverbs to change), and records
the motion before and after planting, what was playing at every frame, and how planting went.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..errors import AdverbsError
from ..limits import check_frames
from ..kinematics.floor import Floor
from ..motion.clip import Clip
from ..feet.offline import PlantingReport, report_of_modes
from ..verb.synthesis import MAX_FPS, plan
from .easing import Easing
from .planted import know_levels, plant, planter
from .player import first_frame, step
from .queue import command
from .state import GraphState, new_state
from .structure import CommandRefused, Graph

if TYPE_CHECKING:
    from ..verb.tables import Verb

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
    cues: list[tuple[float, str, str]] = field(default_factory=list)  # (time, the cue in words, what became of it)
    eases: list[tuple[float, float]] = field(default_factory=list)  # each adverb change: (its time, seconds eased over)

    def cue_lines(self) -> list[str]:
        """Every cue of the script, a line each: its time, what it asked, what became of it."""
        return [f"{t:7.2f} s  {what}: {outcome}" for t, what, outcome in self.cues]


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
    from_start: bool = False,
    planned: bool = False,
    ease: float | None = None,
    stay: bool = False,
) -> Performance:
    """Play ``seconds`` of one creature through ``graph`` at ``fps``, following ``script``; plant its feet on ``floor``
    (default: flat, at the level of the first verb that holds feet).

    The frames are those shown at ``dt, 2 dt, …, seconds``; with ``from_start``, the frame at time 0 too (the
    start of the first verb, as :func:`~adverbs.graph.player.first_frame` shows it). A cue whose command is
    refused (an unknown or unreachable verb, a bad adverb) is recorded in :attr:`Performance.refused` and the
    creature carries on.

    ``planned``: the caller has checked the start point, the length and the frame rate as a synthesis does
    (:func:`~adverbs.verb.synthesis.plan`, which :func:`repeat` calls), so ``synth`` gives one answer whatever
    the number of cycles; otherwise they are held to a graph's range (:meth:`Graph.check_point`), at most
    ``MAX_SECONDS`` and 1 to ``MAX_FPS`` frames a second.

    An adverb cue eases from the point shown to the one asked for over ``ease`` seconds (smoothstep; 0: at once),
    as the run time's adverb changes do, so a cue during a gesture does not snap its pose; by default (None) over
    as long as the change needs for no part of the body to turn faster than its verbs' own
    (:func:`~adverbs.graph.easing.ease_length`: 0.5 to 3 s). :attr:`Performance.eases` records each change's.

    ``stay``: the first verb, and each verb a cue asks for, keeps playing, through its loop into itself, until a cue
    asks for another (a verb without a loop goes on by a drawn transition to one that has, and stays there: see
    :func:`~adverbs.graph.queue.command`); otherwise the queue draws every next transition by likelihood, and a
    creature left without cues wanders the graph.
    """
    if planned:
        point = graph.point(adverbs)
    else:
        if not (np.isfinite(seconds) and 0 < seconds <= MAX_SECONDS):
            raise AdverbsError(f"seconds must be a number in (0, {MAX_SECONDS:g}], got {seconds}")
        if not (np.isfinite(fps) and 1 <= fps <= MAX_FPS):
            raise AdverbsError(f"fps must be a number from 1 to {MAX_FPS:g}, got {fps}")
        point = graph.check_point(graph.point(adverbs))  # a point far outside would play degenerate cycles
    state = new_state(graph, 1, seed, start, point[None], np.asarray(root, dtype=float)[None], stay=stay)
    feet = planter(graph, 1, floor) if any(v.holds for v in graph.verbs) else None
    cues = sorted(script, key=lambda c: c.time)
    frames = int(round(seconds * fps)) + int(from_start)
    check_frames(frames, graph.skeleton.num_joints, f"{seconds:g} s at {fps:g} fps")
    dt = 1.0 / fps
    j = graph.skeleton.num_joints
    rot, trans = np.empty((frames, j, 4)), np.empty((frames, j, 3))
    free_rot, free_trans = np.empty((frames, j, 4)), np.empty((frames, j, 3))
    playing, active, verb = [], np.empty(frames, dtype=np.int64), np.empty(frames, dtype=np.int64)
    legs = len(feet.tips) if feet is not None else 0
    modes, turns, drops = np.zeros((frames, legs), dtype=np.int64), np.zeros((frames, legs)), np.zeros(frames)
    easing = Easing(state.points)
    refused: list[tuple[float, str]] = []
    outcomes: list[list] = []  # per cue: [time, words, what became of it]
    eases: list[tuple[float, float]] = []
    waiting: int | None = None  # the cue whose verb has not played alone yet
    unreachable, miss = 0, 0.0
    k = 0
    for f in range(frames):
        now = (f - int(from_start)) * dt
        while k < len(cues) and cues[k].time <= now + 1e-9:
            cue = cues[k]
            k += 1
            outcomes.append([cue.time, _words(cue), "ran"])
            try:
                if cue.adverbs:
                    over = easing.ease_to(graph, state, 0, easing.cued(graph, 0, cue.adverbs), now, ease)
                    eases.append((cue.time, over))
                    outcomes[-1][2] = f"adverbs set, eased over {over:.2f} s"
                if cue.verb is not None:
                    arrived = len(state.latencies)
                    command(state, 0, cue.verb, stay=stay)
                    if waiting is not None:
                        outcomes[waiting][2] = f"superseded by the cue at {cue.time:g} s before {outcomes[waiting][1]} played"
                    waiting = len(outcomes) - 1
                    outcomes[waiting][2] = "queued"
                    if len(state.latencies) > arrived:  # playing it already
                        outcomes[waiting][2] = f"{cue.verb} playing already (at {now:.2f} s)"
                        waiting = None
            except (CommandRefused, AdverbsError) as e:
                refused.append((cue.time, str(e)))
                done = f"{outcomes[-1][2]}; " if outcomes[-1][2].startswith("adverbs set") else ""  # the verb refused, its adverbs kept
                outcomes[-1][2] = f"{done}refused: {e}"
        before = len(state.latencies)
        first = from_start and f == 0
        easing.apply(state.points, now if first else now + dt)
        if feet is not None:
            know_levels(feet, state)
        frame = first_frame(state) if first else step(state, dt)
        free_rot[f], free_trans[f] = frame.rotations[0], frame.translations[0]
        if feet is not None:
            r, t, result = plant(feet, frame, dt, state.alone, state.standing)
            rot[f], trans[f] = r[0], t[0]
            modes[f], turns[f] = feet.mode[0], feet.turn[0]
            drops[f] = result.root_drop[0]
            unreachable += int(np.count_nonzero(result.unreachable))
            if result.unreachable.any():
                miss = max(miss, float(result.residual[result.unreachable].max()))
        else:
            rot[f], trans[f] = free_rot[f], free_trans[f]
        playing.append(state.playing(0))
        active[f], verb[f] = state.active[0], state.verb[0]
        if waiting is not None and len(state.latencies) > before:
            _, name, latency = state.latencies[-1]
            outcomes[waiting][2] = f"{name} playing alone at {outcomes[waiting][0] + latency:.2f} s ({latency:.2f} s later)"
            waiting = None
    if waiting is not None:
        outcomes[waiting][2] = f"{outcomes[waiting][1]} not playing alone by the end ({(frames - int(from_start)) * dt:.2f} s)"
    end = (frames - 1 - int(from_start)) * dt
    outcomes += [[c.time, _words(c), f"not played: after the last frame ({end:.2f} s)"] for c in cues[k:]]
    report = report_of_modes(modes, turns, drops, unreachable, miss)
    name = graph.name
    planted = Clip(graph.skeleton, rot, trans, fps, name=name)
    free = Clip(graph.skeleton, free_rot, free_trans, fps, name=name)
    return Performance(planted, free, playing, active, verb, report, refused, state, [tuple(o) for o in outcomes], eases)


def _words(cue: Cue) -> str:
    """A cue in words: the verb, the adverbs, or both."""
    parts = [] if cue.verb is None else [str(cue.verb)]
    parts += [f"{k}={v:g}" for k, v in (cue.adverbs or {}).items()]
    return ", ".join(parts) or "(nothing)"


def repeat(
    verb: Verb,
    p: np.ndarray,
    duration: float | None = None,
    cycles: float | None = None,
    fps: float | None = None,
    floor: Floor | None = None,
) -> tuple[Performance, np.ndarray]:
    """A cyclic verb at adverb point ``p`` played ``cycles`` times (or for ``duration`` seconds), each cycle going on
    into the next through the verb's own loop into itself (§5: :meth:`Graph.of_verb`), its feet planted on ``floor``.

    What ``adverbs synth --cycles`` writes: the frames are those of :func:`~adverbs.verb.synthesis.synthesize` (time
    0 to the end, at the verb's fps unless given), checked the same way before any work. Returns the performance and
    the keytimes ``(N,)`` of one cycle at ``p``.
    """
    if not verb.cyclic:
        raise AdverbsError(f"verb {verb.name!r} is a one-shot motion: it has no cycle to repeat")
    p, state, clocks, fps = plan(verb, p, duration, cycles, fps)
    graph = Graph.of_verb(verb)
    performance = perform(
        graph, seconds=float(clocks[-1]), fps=fps, floor=floor, adverbs=dict(zip(verb.adverb_names, p)), from_start=True,
        planned=True,
    )  # fmt: skip
    return performance, state.keytimes[0].copy()
