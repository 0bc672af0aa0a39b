"""Crowd benchmark: one frame of 1 to 10,000 creatures on the shipped graphs, feet planted, through the one compiled
pass (:class:`adverbs.runtime.frame.FramePass`) on one thread and on every thread, beside the readable reference
path (:func:`adverbs.graph.player.step` then :func:`~adverbs.graph.planted.plant`, the frame as it was).

    .venv/bin/python benchmarks/crowd.py            (part of make bench)
    .venv/bin/python benchmarks/crowd.py --goals    (the goal rows alone)

Each creature starts in a random verb of the graph at a random place and heading and is told to perform a random
verb every few seconds (a command is an event, done between frames and not timed: it costs the same on both
paths); between commands it takes the graph's default transitions, so a crowd is always partly in blends. After
a second untimed (kernels loaded, every path taken), the frames of the next seconds are timed one by one: the
table gives the median ms a frame and µs per creature. The last rows time 1,000 creatures playing the reach, each
moving its reach goal (its adverbs) every frame: the goal chain solved anew for every creature, every frame; beside
them the same crowd with its goals still (the frame without a solve), and the solve alone (``SamplingState.update``
of the reach for the 1,000 moved points, which also recomputes their weights and keytimes) in µs per creature. The
compiled columns run the goal chain's solve on as many threads as the pass (``adverbs.verb.goal.THREADS``).
"""

from __future__ import annotations

import statistics
import sys
import time
import warnings
from pathlib import Path

import numba
import numpy as np
from timing import print_table

from adverbs.errors import AdverbsWarning
from adverbs.graph import load_graph
from adverbs.graph.planted import plant, planter
from adverbs.graph.player import step
from adverbs.graph.queue import command
from adverbs.graph.state import new_state
from adverbs.runtime.frame import FramePass
from adverbs.verb import goal as goals

GRAPHS = Path(__file__).resolve().parent.parent / "graphs"
DT = 1.0 / 30.0
SIZES = (1, 100, 1_000, 10_000)


def _crowd(graph, n: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    side = int(np.ceil(np.sqrt(n)))
    roots = np.c_[3.0 * (np.arange(n) % side), 3.0 * (np.arange(n) // side), rng.uniform(0, 2 * np.pi, n)]
    start = [str(v) for v in rng.choice(graph.verb_names, n)]
    state = new_state(graph, n, seed, start, root=roots)
    return state, planter(graph, n), rng


def frame_ms(graph, n: int, path: str, seconds: float) -> float:
    """Median wall milliseconds of one frame of ``n`` creatures on ``path`` (reference, 1 thread, all threads)."""
    state, feet, rng = _crowd(graph, n)
    if path == "reference":
        def one() -> None:
            frame = step(state, DT)
            plant(feet, frame, DT, state.alone, state.standing)
    else:
        fp = FramePass(state, feet, threads=1 if path == "1 thread" else None)

        def one() -> None:
            fp.step(DT)
    times = []
    frames = int(seconds / DT)
    warm = int(1.0 / DT)
    period = int(2.5 / DT)
    due = rng.integers(0, period, n)  # each creature's command frame in every 2.5 s
    for f in range(warm + frames):
        for c in np.flatnonzero(due == f % period):
            command(state, int(c), str(rng.choice(graph.verb_names)), stay=bool(rng.random() < 0.5))
        t = time.perf_counter()
        one()
        if f >= warm:
            times.append(time.perf_counter() - t)
    return statistics.median(times) * 1e3


def goal_ms(graph, n: int, compiled: bool, frames: int = 20, move: bool = True, threads: int | None = None) -> float:
    """Median ms a frame of ``n`` creatures playing the reach, each moving its goal (hand_x, hand_y, hand_z) a little
    every frame (``move``; else the goals stay where they start); the compiled pass and the goal chain's solve on
    ``threads`` threads (default: all)."""
    state = new_state(graph, n, 0, "reach", stay=True)
    feet = planter(graph, n)
    fp = FramePass(state, feet, threads=threads) if compiled else None
    goals.THREADS = threads
    cols = [graph.adverb_names.index(a) for a in ("hand_x", "hand_y", "hand_z")]
    lo, hi = graph.adverb_range(0.0)
    rng = np.random.default_rng(1)
    state.points[:, cols] = rng.uniform(lo[cols], hi[cols], (n, 3))
    times = []
    for f in range(frames + 3):
        if move:
            state.points[:, cols] = np.clip(state.points[:, cols] + rng.normal(0, 0.005, (n, 3)), lo[cols], hi[cols])
        t = time.perf_counter()
        if fp is not None:
            fp.step(DT)
        else:
            plant(feet, step(state, DT), DT, state.alone, state.standing)
        if f >= 3:
            times.append(time.perf_counter() - t)
    goals.THREADS = None
    return statistics.median(times) * 1e3


def solve_us(graph, n: int, frames: int = 20, threads: int | None = None) -> float:
    """Median µs per creature of bringing the reach's sampling cache of ``n`` creatures up to date when every one's
    goal moved a little (as in :func:`goal_ms`): weights, keytimes and the goal chain's solve, on ``threads``."""
    goals.THREADS = threads
    verb = graph.verbs[graph.verb_names.index("reach")]
    lo, hi = verb.points.min(axis=0), verb.points.max(axis=0)
    rng = np.random.default_rng(1)
    points = rng.uniform(lo, hi, (n, 3))
    state = verb.state(n)
    state.update(verb, points)
    times = []
    for _ in range(frames):
        points = np.clip(points + rng.normal(0, 0.005, (n, 3)), lo, hi)
        t = time.perf_counter()
        state.update(verb, points)
        times.append(time.perf_counter() - t)
    goals.THREADS = None
    return statistics.median(times) * 1e6 / n


def goal_rows(graph) -> list[tuple[str, ...]]:
    """The goal rows of the table: 1,000 creatures reaching, goals moved every frame and still, and the solve alone."""
    rows = []
    for what, move in (("every goal moved every frame", True), ("goals still", False)):
        cells = [f"{goal_ms(graph, 1000, compiled, move=move, threads=t):.1f} ms" for compiled, t in
                 ((False, None), (True, 1), (True, None))]  # fmt: skip
        rows.append((f"bandai, 1,000 reaching, {what}", *cells))
    solve = [f"{solve_us(graph, 1000, threads=t):.1f} µs" for t in (1, None)]
    rows.append(("bandai, reach: a moved goal's update and solve (µs per creature)", "", *solve))
    return rows


def main() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        graphs = {name: load_graph(GRAPHS / f"{name}.toml") for name in ("bandai", "cmu")}
    threads = numba.config.NUMBA_NUM_THREADS
    header = ("one frame, feet planted (median; µs per creature)", "today's path (reference)", "compiled, 1 thread",
              f"compiled, {threads} threads")  # fmt: skip
    if "--goals" in sys.argv[1:]:
        print_table(header, goal_rows(graphs["bandai"]))
        return
    rows = []
    for name, graph in graphs.items():
        for n in SIZES:
            seconds = 3.0 if n <= 1_000 else 1.0
            cells = []
            for path in ("reference", "1 thread", f"{threads} threads"):
                ms = frame_ms(graph, n, path if path != f"{threads} threads" else "all", seconds)
                cells.append(f"{ms:.3f} ms ({ms * 1e3 / n:.1f} µs)" if n < 1_000 else f"{ms:.1f} ms ({ms * 1e3 / n:.1f} µs)")
            rows.append((f"{name}, {n:,} creature{'s' if n > 1 else ''}", *cells))
    rows += goal_rows(graphs["bandai"])
    print_table(header, rows)


if __name__ == "__main__":
    main()
