"""Run-time benchmark: a simulation on the virtual clock (the whole loop: events, graph step, planted feet,
recording off) of 1, 100 and 1,000 creatures on the Bandai graph, each told to walk, run or stand every few
seconds; frames per second of the whole crowd.

    make bench            (or: .venv/bin/python benchmarks/runtime.py)
    .venv/bin/python benchmarks/runtime.py --ease     (the second table alone)

Prints a Markdown table: after one untimed run of the same scenario (numba's cached kernels loaded, every code
path taken once), the median of three timed runs on this machine. A second table gives what an adverb change
given no ``over`` costs when it is asked for (``easing.ease_length``, worked out at the change: an event, not a
frame), median of 20 changes, for a verb of each kind.
"""

from __future__ import annotations

import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from timing import print_table

from adverbs.errors import AdverbsWarning
from adverbs.graph import load_graph
from adverbs.graph.easing import ease_length
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


def ease_ms(graph, verb: str, adverb: str, to: float, changes: int = 20) -> tuple[float, float]:
    """Median ms of working out the default ease of a change of ``adverb`` to ``to`` from the graph's default point,
    for a creature playing ``verb``; and the ease (s)."""
    shown = graph.point({})
    target = graph.point({adverb: to})
    v = [graph.verb_index(verb)]
    ease_length(graph, v, shown, target)
    times = []
    for _ in range(changes):
        t = time.perf_counter()
        seconds = ease_length(graph, v, shown, target)
        times.append(time.perf_counter() - t)
    return statistics.median(times) * 1e3, seconds


def ease_table() -> None:
    rows = []
    for name, verb, adverb, to in (("bandai", "idle", "valence", 0.8), ("bandai", "walk", "valence", 0.8),
                                   ("bandai", "bow", "valence", -0.8), ("cmu", "walk", "walk_speed", 1.6)):  # fmt: skip
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", AdverbsWarning)
            graph = load_graph(GRAPHS / f"{name}.toml")
        ms, seconds = ease_ms(graph, verb, adverb, to)
        rows.append((f"{name} {verb}, {adverb} to {to:g}", f"{ms:.2f} ms", f"{seconds:.2f} s"))
    print_table(("an adverb change, no over given", "working out its ease (median)", "its ease"), rows)


def main() -> None:
    if "--ease" in sys.argv:
        ease_table()
        return
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
    print()
    ease_table()


if __name__ == "__main__":
    main()
