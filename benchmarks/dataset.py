"""Motion datasets: clips per second made by ``adverbs dataset`` in one process (no cluster), and on a local Dask
cluster of one and of two worker processes, the same spec each time (and the same bytes: checked).

    .venv/bin/python benchmarks/dataset.py [--clips N]      (part of make bench; about three minutes)

The spec: the CMU walk and run and the Bandai styled walk (2-4 s each, Sobol and Latin hypercube points, a tenth of
their range past the examples), the Bandai reach (Sobol) and bow (played once), and the CMU graph under random scripts
(6 s, a command every 1-3 s); arrays only, 50 clips a shard. Each configuration runs in a fresh process, as a user's
command would, and is timed whole (reading the spec, building the verbs once, starting the cluster and its workers,
which load the compiled kernels from numba's cache, making and writing every shard) and after start-up (from the
moment every worker has finished a shard to the last shard).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from timing import print_table

ROOT = Path(__file__).resolve().parent.parent
HEAD = 'name = "bench"\nseed = 3\nformats = ["arrays"]\nshard_size = 50\n'
ENTRIES = [  # (table, key, file, its own lines)
    ("verbs", "spec", "specs/cmu_walk.toml", 'sampler = "sobol"\nmargin = 0.1\nduration = [2.0, 4.0]'),
    ("verbs", "spec", "specs/cmu_run.toml", 'sampler = "sobol"\nmargin = 0.1\nduration = [2.0, 4.0]'),
    ("verbs", "spec", "specs/bandai_styled_walk.toml", 'sampler = "lhs"\nduration = [2.0, 4.0]'),
    ("verbs", "spec", "specs/bandai_reach.toml", 'sampler = "sobol"'),
    ("verbs", "spec", "specs/bandai_bow.toml", ""),
    ("graphs", "graph", "graphs/cmu.toml", "duration = 6.0\nevery = [1.0, 3.0]"),
]


def spec_text(n: int) -> str:
    """The benchmark's spec: ``n`` clips of each entry."""
    return HEAD + "".join(f'\n[[{t}]]\n{k} = "{ROOT / f}"\nclips = {n}\n{own}\n' for t, k, f, own in ENTRIES)


RUN = """import json, sys, time
import adverbs
started = time.perf_counter()
times = []
if __name__ == "__main__":
    s = adverbs.dataset(sys.argv[1], sys.argv[2], workers=int(sys.argv[3]), on_shard=lambda r: times.append((time.perf_counter(), len(r.rows))))
    print(json.dumps({"wall": time.perf_counter() - started, "clips": s.clips, "times": [[t - started, n] for t, n in times], "complete": s.complete}))
"""


def measure(spec: Path, out: Path, workers: int) -> dict:
    r = subprocess.run([sys.executable, "-c", RUN, str(spec), str(out), str(workers)], capture_output=True, text=True, check=True)
    result = json.loads(r.stdout.strip().splitlines()[-1])
    assert result["complete"], r.stderr
    times = result["times"]
    k = max(workers, 1)  # every worker has made a shard: started up
    steady = sum(n for _, n in times[k:]) / (times[-1][0] - times[k - 1][0])
    result.update(steady=steady, startup=times[k - 1][0])
    return result


def digest(folder: Path) -> str:
    h = hashlib.sha256()
    for p in sorted(folder.rglob("*")):
        if p.is_file() and p.name != "spec.toml":
            h.update(str(p.relative_to(folder)).encode() + p.read_bytes())
    return h.hexdigest()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clips", type=int, default=200, help="clips per verb and graph (default 200: 1,200 in all)")
    args = parser.parse_args()
    rows, digests = [], set()
    print(f"load average before: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores (anything else running skews the table)")
    with tempfile.TemporaryDirectory() as folder:
        spec = Path(folder) / "bench.toml"
        spec.write_text(spec_text(args.clips))
        for label, workers in (("one process, no cluster (--workers 0)", 0), ("LocalCluster, 1 worker", 1), ("LocalCluster, 2 workers", 2)):  # fmt: skip
            out = Path(folder) / f"out{workers}"
            m = measure(spec, out, workers)
            digests.add(digest(out))
            rows.append((label, f"{m['clips']:,}", f"{m['wall']:.1f} s", f"{m['clips'] / m['wall']:.1f}", f"{m['startup']:.1f} s", f"{m['steady']:.1f}"))  # fmt: skip
    print_table(("how", "clips", "wall", "clips/s (whole run)", "first shard per worker", "clips/s after start-up"), rows)
    print(f"\nthe same files every way: {'yes' if len(digests) == 1 else 'NO'}")


if __name__ == "__main__":
    main()
