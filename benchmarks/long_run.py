"""Long recorded runs: 20 creatures on the Bandai graph for 1 minute and for 30 minutes, recorded and written as BVH
by ``adverbs run`` at the default limits, each in its own process; its peak memory (resident set) and wall time.

    .venv/bin/python benchmarks/long_run.py            (part of make bench; about five minutes)

The recording is kept on disk as the run goes (:mod:`adverbs.runtime.recording`) and each creature's file is
written from it alone, a block of frames at a time, so memory does not grow with the length of the run.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from timing import print_table

ROOT = Path(__file__).resolve().parent.parent
CREATURES = 20
RUN = """import resource, sys
from adverbs.apps.cli import main
code = main(sys.argv[1:])
print(f"peak {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss}", file=sys.stderr)
sys.exit(code)
"""


def script(seconds: float, folder: Path) -> Path:
    """A timed script: 20 creatures in a grid, each told to perform a random verb every 10-30 s."""
    rng = np.random.default_rng(0)
    verbs = ["walk", "run", "idle", "walk", "bow", "reach"]
    lines = [f"seconds = {seconds:g}", "fps = 30", "seed = 1", f'graphs = ["{ROOT / "graphs" / "bandai.toml"}"]']
    for k in range(CREATURES):
        lines += ["[[creatures]]", f'name = "c{k}"', 'graph = "bandai"', f"at = [{3.0 * (k % 5):g}, {3.0 * (k // 5):g}]"]
    for k in range(CREATURES):
        t = float(rng.uniform(1, 10))
        while t < seconds:
            lines += ["[[cues]]", f"at = {t:.2f}", f'creature = "c{k}"', f'perform = "{rng.choice(verbs)}"']
            t += float(rng.uniform(10, 30))
    path = folder / f"run{seconds:g}.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def measure(seconds: float, folder: Path) -> tuple[float, float, int]:
    """Peak resident memory (MB), wall seconds and bytes written of one recorded run of ``seconds``."""
    out = folder / f"out{seconds:g}"
    start = time.perf_counter()
    run = subprocess.run(
        [sys.executable, "-c", RUN, "run", "--script", str(script(seconds, folder)), "--out", str(out)],
        capture_output=True, text=True,
    )  # fmt: skip
    wall = time.perf_counter() - start
    if run.returncode != 0:
        raise SystemExit(f"the {seconds:g} s run failed:\n{run.stderr}")
    peak = next(int(line.split()[1]) for line in run.stderr.splitlines() if line.startswith("peak "))
    written = sum(p.stat().st_size for p in out.iterdir())
    return peak / 1024.0, wall, written


def main() -> None:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        results = {s: measure(s, folder) for s in (60.0, 1800.0)}
    base = results[60.0][0]
    for seconds, (peak, wall, written) in results.items():
        rows.append((
            f"{CREATURES} creatures, {seconds / 60:g} min recorded ({seconds * 30:,.0f} frames), BVH written",
            f"{peak:,.0f} MB", f"{peak / base:.2f}×", f"{wall:.0f} s", f"{written / 1e6:,.0f} MB",
        ))  # fmt: skip
    print_table(("adverbs run, Bandai graph, 30 fps", "peak memory", "of the 1-minute run's", "wall", "files"), rows)


if __name__ == "__main__":
    main()
