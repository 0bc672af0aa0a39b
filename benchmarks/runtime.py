"""Run-time benchmark: a simulation on the virtual clock (the whole loop: events, graph step, planted feet,
recording off) of 1, 100 and 1,000 creatures on the Bandai graph, each told to walk, run or stand every few
seconds; frames per second of the whole crowd.

    make bench            (or: .venv/bin/python benchmarks/runtime.py)

Prints a Markdown table: after one untimed run of the same scenario (numba's cached kernels loaded, every code
path taken once), the median of three timed runs on this machine.
"""

from __future__ import annotations

import time
import warnings
from pathlib import Path

import numpy as np
from timing import print_table

from adverbs.errors import AdverbsWarning
from adverbs.graph import load_graph
from adverbs.runtime import Simulation

GRAPHS = Path(__file__).resolve().parent.parent / "graphs"
TARGETS = {1: 2000.0, 100: 60.0}  # frames per second the issue asks for


def frames_per_second(graph, creatures: int, seconds: float = 5.0, plant: bool = True) -> float:
    rng = np.random.default_rng(0)
    sim = Simulation(graph, fps=30.0, seed=1, plant=plant, record=False)
    crowd = [sim.add_creature(at=(3.0 * (k % 40), 3.0 * (k // 40)), heading=float(rng.uniform(0, 360))) for k in range(creatures)]
    for c in crowd:
        for t in np.arange(rng.uniform(0.2, 1.0), seconds, 2.5):
            c.perform(str(rng.choice(["walk", "run", "idle"])), at=float(t))
    sim.run(0.5)  # warm: compiled kernels, caches
    start = time.perf_counter()
    sim.run(seconds)
    return (sim.frames - 15) / (time.perf_counter() - start)


def main() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        graph = load_graph(GRAPHS / "bandai.toml")
    rows = []
    for c in (1, 100, 1000):
        seconds = {1: 10.0, 100: 3.0, 1000: 2.0}[c]
        for plant in (True, False):
            frames_per_second(graph, c, min(seconds, 3.0), plant)  # warm: the scenario's code paths once, untimed
            runs = sorted(frames_per_second(graph, c, seconds, plant) for _ in range(3 if c < 1000 else 1))
            fps = runs[len(runs) // 2]
            target = TARGETS.get(c)
            asked = f"{target:,.0f}" if (target and plant) else "reported"
            rows.append((
                f"{c:,} creature{'s' if c > 1 else ''}, {'feet planted' if plant else 'no planting'}",
                f"{fps:,.0f} frames/s ({1e3 / fps:.2f} ms a frame, {1e6 / fps / c:,.0f} µs per creature)",
                asked,
            ))  # fmt: skip
    print_table(("virtual clock, Bandai graph, 30 fps scene", "measured", "asked"), rows)


if __name__ == "__main__":
    main()
