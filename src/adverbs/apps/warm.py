"""Compile the numba kernels once, as part of set-up (the Makefile runs ``python -m adverbs.apps.warm`` after
installing): a few seconds of the demo's scenario, feet planted, written as BVH and glTF, takes every compiled
loop the main job uses (sampling, time warps, poses, forward kinematics, the planter, IK, Euler angles, the
one-pass frame, the goal chain's solve) through its first call; a second of it on the readable reference path and
without planting takes the rest (``graph --play`` and the tests use them). numba caches what it compiles next to the
package, so later runs load it instead of compiling (about three minutes on a two-core machine, once).
"""

from __future__ import annotations

import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from ..errors import AdverbsWarning
from ..runtime import Simulation
from .scene import DEMO_SCRIPT, run_script


def main() -> None:
    started = time.perf_counter()
    print("compiling the numba kernels (once; later runs load them from numba's cache)", flush=True)
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        sim, _ = run_script([], DEMO_SCRIPT, Path(tmp), seconds=4.0, quiet=True, formats=("bvh", "glb"))
        for compiled, plant in ((False, True), (True, False)):
            other = Simulation(sim.graphs, fps=30, seed=0, plant=plant, record=False, compiled=compiled)
            for graph in sim.graphs:
                other.add_creature(graph=graph).perform(graph.verb_names[-1], at=0.5)
            other.run(1.5)
        for verb in {v for graph in sim.graphs for v in graph.verbs if v.goal is not None}:
            verb.sample(verb.points, np.zeros(len(verb.points)))  # the goal chain's solve (and its tables), compiled
    print(f"compiled in {time.perf_counter() - started:.0f} s", flush=True)


if __name__ == "__main__":
    main()
