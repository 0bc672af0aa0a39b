"""Every clip of a dataset, decided before any is made: its source, adverb point, seed, duration, floor and (for a
graph) script. All of it is drawn from the spec's seed, so the plan — and each clip, a pure function of its task — is
the same on any machine.

Adverb points (:func:`draw_points`) fill each source's adverb range (its examples' span, widened by ``margin`` of it on
each side): a ``grid``, ``uniform`` draws, a scrambled ``sobol`` sequence or a ``lhs`` Latin hypercube
(:mod:`scipy.stats.qmc`), or listed ``points``. Seeds are NumPy :class:`~numpy.random.SeedSequence` children of the
dataset's seed: an entry's points from ``(seed, ENTRY + entry index)``, a clip's own draws from ``(seed, clip id)``.
"""

from __future__ import annotations

import itertools
import json
import warnings
from dataclasses import dataclass

import numpy as np

from ..graph.structure import Graph
from ..limits import check_frames
from ..verb.tables import Verb
from .spec import DEFAULT_GRAPH_FPS, MAX_CLIPS, DatasetSpec, DatasetSpecError, Entry

ENTRY = 1 << 40  # spawn keys of the entries' point draws sit above every clip id


@dataclass(frozen=True)
class ClipTask:
    """What one clip is: a pure function of these fields and its source's data.

    ``clip``: its id (0, 1, … in the spec's order); ``source``: index of its verb or graph; ``adverbs``: (name, value)
    pairs, the verb's point or where the graph performance starts; ``seed``: the clip's own (a graph's default
    transitions are drawn from it); ``duration`` in seconds (None: one cycle of the verb); ``fps`` (None: the verb's);
    ``floor`` ("flat", "flat:LEVEL", "slope:DEG"); ``script``: a graph's cues as JSON text; ``start``: its first verb; ``loop``: how a verb's cycles go on (see the spec).
    """

    clip: int
    source: int
    kind: str
    adverbs: tuple[tuple[str, float], ...]
    seed: int
    duration: float | None
    fps: float | None
    floor: str
    script: str = ""
    start: str | None = None
    loop: str = "graph"


def clip_seed(seed: int, clip: int) -> np.random.SeedSequence:
    """The seed sequence of clip ``clip`` of a dataset seeded ``seed``."""
    return np.random.SeedSequence(seed, spawn_key=(clip,))


def _unit_samples(sampler: str, n: int, dims: int, ss: np.random.SeedSequence) -> np.ndarray:
    """``(n, dims)`` samples in the unit cube."""
    rng = np.random.default_rng(ss)
    if dims == 0:
        return np.zeros((n, 0))
    if sampler == "uniform":
        return rng.random((n, dims))
    from scipy.stats import qmc  # here: scipy.stats takes a second to import, and only these samplers need it

    engine = qmc.Sobol if sampler == "sobol" else qmc.LatinHypercube
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # Sobol's balance note when n is not a power of two
        try:
            return engine(d=dims, rng=rng).random(n)
        except TypeError:  # SciPy before 1.15 calls it seed
            return engine(d=dims, seed=rng).random(n)


def adverb_range(source: Verb | Graph, margin: float) -> tuple[tuple[str, ...], np.ndarray, np.ndarray]:
    """The source's adverb names and the lowest and highest value ``(A,)`` each is drawn from: its examples' span
    widened by ``margin`` of it on each side (a graph: :meth:`Graph.adverb_range`, clamped verbs kept inside)."""
    if isinstance(source, Graph):
        lo, hi = source.adverb_range(margin)
        return source.adverb_names, lo, hi
    a, b = source.points.min(axis=0), source.points.max(axis=0)
    return source.adverb_names, a - margin * (b - a), b + margin * (b - a)


def draw_points(spec: DatasetSpec, index: int, entry: Entry, source: Verb | Graph) -> tuple[tuple[str, ...], np.ndarray]:
    """The adverb names and points ``(n, A)`` of ``entry`` (the ``index``-th of ``spec``), in the order of its clips."""
    names, lo, hi = adverb_range(source, entry.margin)
    where = entry.where
    if entry.sampler == "grid":
        n = entry.grid ** len(names)
        if n > MAX_CLIPS:
            raise DatasetSpecError(spec.path, f"grid {entry.grid} over {len(names)} adverbs is {n:,} clips; at most {MAX_CLIPS:,}", f"{where}.grid")
        axes = [np.linspace(a, b, entry.grid) if entry.grid > 1 else np.array([(a + b) / 2]) for a, b in zip(lo, hi)]
        return names, np.array(list(itertools.product(*axes)), dtype=float).reshape(n, len(names))
    if entry.sampler == "points":
        rows = []
        for j, given in enumerate(entry.points):
            for k in given:
                if k not in names:
                    raise DatasetSpecError(spec.path, f"{entry.kind} {source.name!r} has no adverb {k!r}; its adverbs are {', '.join(names) or 'none'}", f"{where}.points[{j + 1}].{k}")  # fmt: skip
            rows.append(source.point(given))
        count = entry.clips or len(rows)
        return names, np.array([rows[i % len(rows)] for i in range(count)], dtype=float).reshape(count, len(names))
    u = _unit_samples(entry.sampler, entry.clips, len(names), np.random.SeedSequence(spec.seed, spawn_key=(ENTRY + index,)))
    return names, lo + u * (hi - lo)


def _script(rng: np.random.Generator, graph: Graph, entry: Entry, seconds: float, lo: np.ndarray, hi: np.ndarray) -> str:
    """A random script for one performance: a command every ``entry.every`` seconds (a verb drawn uniformly, and new
    adverbs if ``change_adverbs``), as JSON cues ``{"at", "perform", "adverbs"}``."""
    cues, t = [], 0.0
    while True:
        t += float(rng.uniform(*entry.every)) if entry.every[0] < entry.every[1] else entry.every[0]
        if t >= seconds:
            break
        cue = {"at": round(t, 6), "perform": graph.verb_names[int(rng.integers(len(graph.verb_names)))]}
        if entry.change_adverbs and len(lo):
            cue["adverbs"] = dict(zip(graph.adverb_names, (float(x) for x in lo + rng.random(len(lo)) * (hi - lo))))
        cues.append(cue)
    return json.dumps(cues, separators=(",", ":"))


def plan(spec: DatasetSpec, sources: list) -> list[ClipTask]:
    """Every clip of the dataset in id order; ``sources[i]`` is entry ``i``'s verb or graph (loaded). A grid or list
    that asks for more clips than allowed, or a clip past the frame limit, is refused naming the field."""
    tasks: list[ClipTask] = []
    for index, (entry, source) in enumerate(zip(spec.entries, sources)):
        names, points = draw_points(spec, index, entry, source)
        if len(tasks) + len(points) > MAX_CLIPS:
            raise DatasetSpecError(spec.path, f"the dataset would have more than {MAX_CLIPS:,} clips", f"{entry.where}.clips")
        fps = spec.fps if spec.fps is not None or entry.kind == "verb" else DEFAULT_GRAPH_FPS
        if entry.duration is not None:
            rate = fps if fps is not None else source.fps
            check_frames(round(entry.duration[1] * rate) + 1, source.skeleton.num_joints, f"{spec.path}: {entry.where}.duration {entry.duration[1]:g} s at {rate:g} fps")  # fmt: skip
        lo, hi = (adverb_range(source, entry.margin)[1:]) if entry.kind == "graph" else (None, None)
        for p in points:
            clip = len(tasks)
            ss = clip_seed(spec.seed, clip)
            seed = int(ss.generate_state(1, np.uint32)[0])
            rng = np.random.default_rng(ss)
            duration = None
            if entry.duration is not None:
                a, b = entry.duration
                duration = float(rng.uniform(a, b)) if a < b else a
            floor = spec.floors[int(rng.integers(len(spec.floors)))] if len(spec.floors) > 1 else spec.floors[0]
            script = _script(rng, source, entry, duration, lo, hi) if entry.kind == "graph" else ""
            adverbs = tuple(zip(names, (float(x) for x in p)))
            tasks.append(ClipTask(clip, index, entry.kind, adverbs, seed, duration, fps, floor, script, entry.start, entry.loop))
    return tasks
