"""Compile the numba kernels once, as part of set-up (the Makefile runs ``python -m adverbs.apps.warm`` after
installing): a few seconds of the demo's scenario, feet planted, written as BVH and glTF, takes every compiled
loop the main job uses (sampling, time warps, poses, forward kinematics, the planter, IK, Euler angles) through
its first call. numba caches what it compiles next to the package, so later runs load it instead of compiling
(about a minute on a two-core machine, once).
"""

from __future__ import annotations

import tempfile
import time
import warnings
from pathlib import Path

from ..errors import AdverbsWarning
from .scene import DEMO_SCRIPT, run_script


def main() -> None:
    started = time.perf_counter()
    print("compiling the numba kernels (once; later runs load them from numba's cache)", flush=True)
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        run_script([], DEMO_SCRIPT, Path(tmp), seconds=4.0, quiet=True, formats=("bvh", "glb"))
    print(f"compiled in {time.perf_counter() - started:.0f} s", flush=True)


if __name__ == "__main__":
    main()
