"""Verb-graph benchmarks: a frame of C creatures through the Bandai graph (step, and step + planting), and a
seeded 10-minute random walk played twice: its command latency, and that the same seed gives the same
motion frame for frame.

    make bench            (or: .venv/bin/python benchmarks/graph.py)

Prints Markdown tables; medians of repeated runs on this machine.
"""

from __future__ import annotations

import time
import warnings
from pathlib import Path

import numpy as np
from timing import print_table

from adverbs.errors import AdverbsWarning
from adverbs.graph import Cue, command, load_graph, new_state, perform, plant, planter, step

GRAPHS = Path(__file__).resolve().parent.parent / "graphs"
DT = 1.0 / 30.0


def crowd(graph, creatures: int, frames: int = 150) -> tuple[float, float]:
    """Seconds per frame of ``step`` alone and of ``step`` + ``plant`` for ``creatures`` creatures, each told
    to perform a random verb every few seconds (so blends are under way all the time)."""
    rng = np.random.default_rng(1)
    state = new_state(graph, creatures, seed=2)
    feet = planter(graph, creatures)
    walk = graph.verb_index("walk")
    for c in range(creatures):
        command(state, c, walk)
    plain, planted = [], []
    for f in range(frames):
        for c in np.flatnonzero(rng.random(creatures) < DT / 3.0):
            command(state, int(c), str(rng.choice(graph.verb_names)))
        t0 = time.perf_counter()
        frame = step(state, DT)
        t1 = time.perf_counter()
        plant(feet, frame, DT, state.alone, state.standing)
        t2 = time.perf_counter()
        if f >= 10:
            plain.append(t1 - t0)
            planted.append(t2 - t0)
    return float(np.median(plain)), float(np.median(planted))


def main() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        t0 = time.perf_counter()
        graph = load_graph(GRAPHS / "bandai.toml")
        loaded = time.perf_counter() - t0
    rows = [("load the Bandai graph (build its 7 verbs from their specs)", f"{loaded:.1f} s")]
    for c in (1, 100, 1000):
        plain, planted = crowd(graph, c)
        rows.append((f"{c:,} creature{'s' if c > 1 else ''}: one frame, step", f"{plain * 1e3:.2f} ms ({plain / c * 1e6:.0f} µs per creature)"))
        rows.append((f"{c:,} creature{'s' if c > 1 else ''}: one frame, step + planted feet", f"{planted * 1e3:.2f} ms ({planted / c * 1e6:.0f} µs per creature)"))
    rng = np.random.default_rng(2026)
    times = np.cumsum(rng.uniform(2.0, 8.0, 200))
    cues = [Cue(float(t), str(rng.choice(graph.verb_names))) for t in times[times < 590.0]]
    t0 = time.perf_counter()
    first = perform(graph, cues, seconds=600.0, seed=5)
    played = time.perf_counter() - t0
    again = perform(graph, cues, seconds=600.0, seed=5)
    same = np.array_equal(first.planted.rotations, again.planted.rotations) and np.array_equal(
        first.planted.translations, again.planted.translations
    )
    latency = np.array([x for _, _, x in first.state.latencies])
    rows.append(("10-minute random walk (18,000 frames, planted), wall time", f"{played:.0f} s ({played / 18000 * 1e3:.1f} ms per frame)"))
    rows.append(("the same seed again: identical frame for frame", "yes" if same else "NO"))
    rows.append(
        (
            f"command latency over {len(latency)} commands (command → verb playing alone)",
            f"median {np.median(latency):.2f} s, 95th percentile {np.percentile(latency, 95):.2f} s, max {latency.max():.2f} s",
        )
    )
    print_table("verb graph (Bandai)", rows)
    if not same:
        raise SystemExit("the same seed gave a different motion")


if __name__ == "__main__":
    main()
