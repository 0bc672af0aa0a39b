"""One clip, a pure function of its task and its source (:func:`clip`), and one shard of clips rendered to bytes
(:func:`render_shard`): what a worker runs. Nothing here reads or writes a file.

A verb's clip is ``adverbs synth`` at the task's point: one cycle (or the duration asked; a cyclic verb longer than a
cycle goes on through its own loop, :func:`~adverbs.graph.performance.repeat`, or with ``loop = "kernel"`` by
:meth:`Verb.synthesize`'s faded seams), feet planted on the task's floor. A
graph's clip is one creature's performance of the task's script (:func:`~adverbs.graph.performance.perform`), its
default transitions drawn from the task's seed. The feet are measured on the frames written
(:func:`~adverbs.feet.measures.measure_feet`).
"""

from __future__ import annotations

import io
import json
import math
import warnings
import zipfile
from dataclasses import dataclass, field, fields

import numpy as np
from threadpoolctl import threadpool_limits

from ..errors import AdverbsError, AdverbsWarning
from ..feet.measures import FootMetrics, measure_feet
from ..feet.offline import plant_feet, report_of_modes
from ..feet.planter import LIFTED
from ..graph.easing import Easing
from ..graph.performance import MAX_SECONDS, Cue, perform, repeat
from ..graph.planted import know_levels, plant, planter
from ..graph.player import Frame, first_frame, step
from ..graph.queue import command
from ..graph.state import new_state
from ..graph.structure import CommandRefused, Graph
from ..limits import check_frames
from ..io.bvh import format_bvh
from ..io.gltf import format_glb
from ..kinematics.floor import Floor, parse_floor
from ..motion.clip import Clip
from ..verb.sampling import GROUPED
from ..verb.synthesis import MAX_FPS, plan
from ..verb.tables import Verb
from .plan import ClipTask

_EPOCH = (1980, 1, 1, 0, 0, 0)
FEET_COLUMNS = (
    "toe_drift_median_mm", "toe_drift_max_mm", "heel_drift_max_mm", "lowest_mm", "held_height_mm", "slide_max_mm",
    "aloft_max_mm",
)  # fmt: skip


@dataclass
class Made:
    """A clip made: the planted motion, what its feet did (None: nothing is held), what played, warnings."""

    motion: Clip
    feet: FootMetrics | None
    played: str
    warnings: list[str] = field(default_factory=list)


def floor_of(text: str) -> Floor | None:
    """The floor a task names; ``"flat"`` is None: the verb's own floor (a graph's: that of its first verb that holds)."""
    return None if text == "flat" else parse_floor(text)


def clip(source: Verb | Graph, task: ClipTask) -> Made:
    """The clip ``task`` asks of ``source`` (a verb or a graph): the same motion for the same arguments, on any machine.

    An adverb point the verb refuses (a degenerate cycle), a script the graph cannot play, raise
    :class:`~adverbs.errors.AdverbsError`; warnings (a point far past the examples, a refused command, a foot out of
    reach) are returned, not printed."""
    floor = floor_of(task.floor)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", AdverbsWarning)
        made = _graph_clip(source, task, floor) if isinstance(source, Graph) else _verb_clip(source, task, floor)
    made.warnings = [str(w.message) for w in caught if issubclass(w.category, AdverbsWarning)] + made.warnings
    return made


def _verb_clip(verb: Verb, task: ClipTask, floor: Floor | None) -> Made:
    p = verb.point(dict(task.adverbs))
    report = None
    longer = task.duration is not None and task.duration > verb.duration(p) * (1.0 + 1e-9)
    if verb.cyclic and longer and task.loop == "graph":
        looped, _ = repeat(verb, p, duration=task.duration, fps=task.fps, floor=floor)  # cycle into cycle (§5)
        motion, report = looped.planted, looped.report
    else:
        motion, k = verb.synthesize(p, duration=task.duration, fps=task.fps)
        if verb.constraints:
            motion, report = plant_feet(verb, motion, k, floor, p)
    feet = measure_feet(verb, motion, report, floor) if report is not None else None
    return Made(motion, feet, verb.name, list(report.warnings) if report is not None else [])


# Creatures stepped together: fewer than the sampling kernel's GROUPED, from which on it samples by matrix products
# (BLAS), whose last bits differ from its one-by-one loop's: under it a creature samples the same bits in any crowd.
MAX_BATCH = GROUPED - 1


def _graph_clip(graph: Graph, task: ClipTask, floor: Floor | None) -> Made:
    perf = perform(graph, _cues(task), seconds=_seconds(task), fps=task.fps or 30.0, seed=task.seed, floor=floor, start=task.start, adverbs=dict(task.adverbs))  # fmt: skip
    return _performance_made(graph, perf.planted, perf.free, perf.report, perf.verb, perf.refused, floor)


def _cues(task: ClipTask) -> list[Cue]:
    return [Cue(c["at"], c.get("perform"), c.get("adverbs")) for c in json.loads(task.script or "[]")]


def _seconds(task: ClipTask) -> float:
    return task.duration if task.duration is not None else 10.0


def _performance_made(graph: Graph, planted: Clip, free: Clip, report, verbs: np.ndarray, refused: list, floor) -> Made:
    """A graph performance as a clip made: the verbs played in order, its feet measured, refused commands noted."""
    played = [graph.verb_names[v] for v in verbs]
    order = [n for i, n in enumerate(played) if i == 0 or played[i - 1] != n]
    holding = next((v for v in graph.verbs if v.holds), None)
    feet = measure_feet(holding, planted, report, floor, free) if holding is not None else None
    notes = [f"command at {t:g} s refused: {why}" for t, why in refused] + list(report.warnings)
    return Made(planted, feet, " > ".join(order), notes)


def clips(source: Verb | Graph, tasks: list[ClipTask]) -> list[Made | AdverbsError]:
    """:func:`clip` of each task (or the error it raised), the same motions, made faster: a graph's performances, and a
    verb's clips that go on past one cycle through its loop (the default ``loop = "graph"``), are stepped together,
    one creature each, through the graph (:func:`~adverbs.graph.player.step` over every creature at once, its
    per-frame Python paid once), at most :data:`MAX_BATCH` at once; their feet are planted one creature at a time,
    as :func:`clip` plants them, because the compiled planter's vector loop gives a creature other last bits in a
    crowd than alone (1e-15: a clip would depend on its neighbours). ``tests/test_dataset.py`` holds every clip so
    made equal, bit for bit, to :func:`clip` alone."""
    out: list[Made | AdverbsError | None] = [None] * len(tasks)
    together: dict[float, list[tuple[int, _Creature]]] = {}
    for i, task in enumerate(tasks):
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", AdverbsWarning)
                one = _creature(source, task)
            if one is not None:
                one.notes = [str(w.message) for w in caught if issubclass(w.category, AdverbsWarning)]
                together.setdefault(one.fps, []).append((i, one))
                continue
            out[i] = clip(source, task)
        except (AdverbsError, ArithmeticError, ValueError) as e:
            out[i] = e
    graph = Graph.of_verb(source) if isinstance(source, Verb) else source
    for fps, items in together.items():
        for start in range(0, len(items), MAX_BATCH):
            batch = items[start : start + MAX_BATCH]
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", AdverbsWarning)
                made = _together(graph, fps, [x for _, x in batch])
            if any(issubclass(w.category, AdverbsWarning) for w in caught):  # whose? made again one by one, to say
                for i, _ in batch:
                    out[i] = _alone(source, tasks[i])
                continue
            for (i, one), (planted, free, report, verbs, refused) in zip(batch, made):
                floor = one.floor
                if isinstance(source, Graph):
                    out[i] = _performance_made(graph, planted, free, report, verbs, refused, floor)
                    out[i].warnings = one.notes + out[i].warnings
                else:
                    feet = measure_feet(source, planted, report, floor) if report is not None else None
                    out[i] = Made(planted, feet, source.name, one.notes + (list(report.warnings) if report is not None else []))
    return out


def _alone(source: Verb | Graph, task: ClipTask) -> Made | AdverbsError:
    try:
        return clip(source, task)
    except (AdverbsError, ArithmeticError, ValueError) as e:
        return e


@dataclass
class _Creature:
    """One clip as a creature of :func:`_together`: where it starts, for how many frames, on what floor, its cues."""

    point: np.ndarray
    frames: int
    fps: float
    floor: Floor | None
    seed: int = 0
    start: str | None = None
    cues: list[Cue] = field(default_factory=list)
    from_start: bool = False
    notes: list[str] = field(default_factory=list)


def _creature(source: Verb | Graph, task: ClipTask) -> _Creature | None:
    """The task as a creature to step with others, checked as :func:`clip` checks it (the same refusals), or None if
    it is not made that way (a verb's single cycle or faded seams)."""
    floor = floor_of(task.floor)
    if isinstance(source, Graph):
        fps, seconds = task.fps or 30.0, _seconds(task)
        if not (np.isfinite(seconds) and 0 < seconds <= MAX_SECONDS and 1 <= fps <= MAX_FPS):
            return None  # perform refuses it, with its message
        point = source.check_point(source.point(dict(task.adverbs)))
        if task.start is not None:
            source.verb_index(task.start)
        frames = int(round(seconds * fps))
        check_frames(frames, source.skeleton.num_joints, f"{seconds:g} s at {fps:g} fps")
        return _Creature(point, frames, fps, floor, task.seed, task.start, sorted(_cues(task), key=lambda c: c.time))
    if not (source.cyclic and task.loop == "graph" and task.duration is not None):
        return None
    p = source.point(dict(task.adverbs))
    if not task.duration > source.duration(p) * (1.0 + 1e-9):
        return None
    _, _, times, fps = plan(source, p, task.duration, None, task.fps)  # refused and warned as repeat() would
    return _Creature(p, len(times) - 1, fps, floor, from_start=True)  # and the frame at time 0


def _together(graph: Graph, fps: float, creatures: list[_Creature]) -> list[tuple]:
    """:func:`~adverbs.graph.performance.perform` of each creature (its start, cues, seed and floor), all stepped
    together: per creature the planted and free clips, the planting report, the verb playing at every frame and the
    commands refused. A verb's loop is the performance of its one-verb graph from time 0 (``from_start``), as
    :func:`~adverbs.graph.performance.repeat` plays it."""
    c = len(creatures)
    frames = [x.frames + int(x.from_start) for x in creatures]
    state = new_state(
        graph, c, 0, [x.start for x in creatures], np.array([x.point for x in creatures]), np.zeros((c, 3)),
        seeds=[x.seed for x in creatures],
    )  # fmt: skip
    holds = any(v.holds for v in graph.verbs)
    feet = [planter(graph, 1, x.floor) for x in creatures] if holds else []
    j, dt, from_start = graph.skeleton.num_joints, 1.0 / fps, creatures[0].from_start
    rot, trans = [np.empty((n, j, 4)) for n in frames], [np.empty((n, j, 3)) for n in frames]
    free_rot, free_trans = [np.empty((n, j, 4)) for n in frames], [np.empty((n, j, 3)) for n in frames]
    legs = len(feet[0].planter.tips) if holds else 0
    modes = [np.zeros((n, legs), dtype=np.int64) for n in frames]
    turns, drops = [np.zeros((n, legs)) for n in frames], [np.zeros(n) for n in frames]
    verbs = [np.empty(n, dtype=np.int64) for n in frames]
    unreachable, miss, refused, next_cue = [0] * c, [0.0] * c, [[] for _ in range(c)], [0] * c
    easing = Easing(state.points)  # adverb cues eased as perform() eases them
    for f in range(max(frames)):
        now = (f - int(from_start)) * dt
        for k, x in enumerate(creatures):  # the cues due, as perform() takes them
            while f < frames[k] and next_cue[k] < len(x.cues) and x.cues[next_cue[k]].time <= now + 1e-9:
                cue = x.cues[next_cue[k]]
                next_cue[k] += 1
                try:
                    if cue.adverbs:
                        easing.ease_to(graph, state, k, easing.cued(graph, k, cue.adverbs), now, None)
                    if cue.verb is not None:
                        command(state, k, cue.verb)
                except (CommandRefused, AdverbsError) as e:
                    refused[k].append((cue.time, str(e)))
        first = from_start and f == 0
        easing.apply(state.points, now if first else now + dt)
        if holds:
            for k in range(c):
                if f < frames[k]:
                    know_levels(feet[k], state, slice(k, k + 1))
        frame = first_frame(state) if first else step(state, dt)
        for k in range(c):
            if f >= frames[k]:
                continue
            free_rot[k][f], free_trans[k][f], verbs[k][f] = frame.rotations[k], frame.translations[k], state.verb[k]
            if not holds:
                rot[k][f], trans[k][f] = frame.rotations[k], frame.translations[k]
                continue
            one = Frame(*(getattr(frame, x.name)[k : k + 1].copy() for x in fields(Frame)))
            r, t, result = plant(feet[k], one, dt, state.alone[k : k + 1], state.standing[k : k + 1])
            rot[k][f], trans[k][f] = r[0], t[0]
            modes[k][f], turns[k][f], drops[k][f] = feet[k].planter.shown_mode[0], feet[k].planter.rolled[0], result.root_drop[0]
            unreachable[k] += int(np.count_nonzero(result.unreachable))
            if result.unreachable.any():
                miss[k] = max(miss[k], float(result.residual[result.unreachable].max()))
    return [
        (Clip(graph.skeleton, rot[k], trans[k], fps, name=graph.name),
         Clip(graph.skeleton, free_rot[k], free_trans[k], fps, name=graph.name),
         report_of_modes(modes[k], turns[k], drops[k], unreachable[k], miss[k]),
         verbs[k], refused[k])
        for k in range(c)
    ]  # fmt: skip


def feet_figures(feet: FootMetrics | None) -> dict:
    """The manifest's planted-feet columns (millimetres; NaN where nothing was held), ``unreachable`` effector-frames
    and ``never_down``: the feet that never came within ``LIFTED`` of their contact height."""
    nan = math.nan
    if feet is None:
        return {**dict.fromkeys(FEET_COLUMNS, nan), "unreachable": 0, "never_down": ""}

    def mm(x: np.ndarray, f) -> float:
        return float(1000 * f(x)) if len(x) else nan

    return {
        "toe_drift_median_mm": mm(feet.toe_drift, np.median),
        "toe_drift_max_mm": mm(feet.toe_drift, np.max),
        "heel_drift_max_mm": mm(feet.heel_drift, np.max),
        "lowest_mm": 1000 * feet.lowest,
        "held_height_mm": 1000 * feet.held_height,
        "slide_max_mm": mm(feet.slide, np.max),
        "aloft_max_mm": mm(feet.aloft, np.max),
        "unreachable": int(feet.unreachable),
        "never_down": ",".join(n for n, a in zip(feet.feet, feet.aloft) if a > LIFTED),
    }


# ----- a shard --------------------------------------------------------------------------------------


def clip_name(clip_id: int) -> str:
    """A clip's name in files and array keys: ``c00000042``."""
    return f"c{clip_id:08d}"


def shard_folder(shard: int) -> str:
    return f"shards/{shard:06d}"


def npz_bytes(arrays: dict[str, np.ndarray]) -> bytes:
    """``arrays`` as an ``.npz`` (what :func:`numpy.savez` writes, read back with ``np.load(allow_pickle=False)``), but
    the same bytes every time: every member dated 1980-01-01 (NumPy's own stamps the time of writing)."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_STORED, allowZip64=True) as z:
        for key, a in arrays.items():
            member = io.BytesIO()
            np.lib.format.write_array(member, np.ascontiguousarray(a), allow_pickle=False)
            z.writestr(zipfile.ZipInfo(f"{key}.npy", _EPOCH), member.getvalue())
    return buf.getvalue()


@dataclass
class ShardResult:
    """A shard rendered: its files (path in the dataset → bytes) and one manifest row per clip, in clip order."""

    shard: int
    files: dict[str, bytes]
    rows: list[dict]


def render_shard(shard: int, tasks: list[ClipTask], sources: list, formats: tuple[str, ...], portable: bool) -> ShardResult:
    """Make every clip of a shard and its files; ``sources[i]`` is the loaded verb or graph of ``tasks[*].source == i``
    (only those the shard uses need be there). A clip that fails is a row with its error, and the rest go on.
    BLAS runs on one thread, so a clip's numbers are the same in a process of many threads or of one."""
    folder = shard_folder(shard)
    files: dict[str, bytes] = {}
    arrays: dict[str, np.ndarray] = {}
    rows = []
    with threadpool_limits(1):
        made_by_source = {}
        for s in sorted({t.source for t in tasks}):
            mine = [t for t in tasks if t.source == s]
            made_by_source.update(zip((t.clip for t in mine), clips(sources[s], mine)))
        for task in tasks:
            row = _row(task, shard)
            row["source"] = sources[task.source].name
            name = clip_name(task.clip)
            try:
                made = made_by_source[task.clip]
                if isinstance(made, Exception):
                    raise made
                motion = made.motion
                if "arrays" in formats:
                    arrays[f"{name}_rotations"] = motion.rotations.astype(np.float32)
                    arrays[f"{name}_positions"] = motion.global_positions().astype(np.float32)
                    row["arrays"] = f"{folder}/arrays.npz"
                for fmt in ("bvh", "glb"):
                    if fmt in formats:
                        path = f"{folder}/{name}.{fmt}"
                        files[path] = format_bvh(motion, portable=portable).encode() if fmt == "bvh" else format_glb(motion)
                        row[fmt] = path
                row.update(frames=motion.num_frames, fps=float(motion.fps), seconds=motion.num_frames / motion.fps, played=made.played)
                row.update(feet_figures(made.feet))
                row["warnings"] = "\n".join(made.warnings)
            except (AdverbsError, ArithmeticError, ValueError) as e:  # this clip, recorded; the others go on
                row.update(status="failed", error=f"{type(e).__name__}: {e}")
            rows.append(row)
    if arrays:
        files[f"{folder}/arrays.npz"] = npz_bytes(arrays)
    return ShardResult(shard, files, rows)


def _row(task: ClipTask, shard: int) -> dict:
    """A manifest row before the clip is made: what was asked (see :data:`adverbs.dataset.manifest.SCHEMA`)."""
    return {
        "clip": task.clip,
        "name": clip_name(task.clip),
        "kind": task.kind,
        "source": "",
        "adverbs": list(task.adverbs),
        "script": task.script,
        "seed": task.seed,
        "floor": task.floor,
        "duration": math.nan if task.duration is None else task.duration,
        "fps": math.nan,
        "frames": 0,
        "seconds": 0.0,
        "played": "",
        **feet_figures(None),
        "shard": shard,
        "arrays": "",
        "bvh": "",
        "glb": "",
        "status": "ok",
        "error": "",
        "warnings": "",
    }
