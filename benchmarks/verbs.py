"""Verb benchmarks: build time, pose evaluation (single and batched) beside scipy's RBFInterpolator.

    make bench            (or: .venv/bin/python benchmarks/verbs.py)

Prints a Markdown table; medians of repeated runs on this machine.
"""

from __future__ import annotations

import dataclasses
import statistics
import time
from pathlib import Path

import numpy as np
from timing import median_seconds, print_table
from scipy.interpolate import RBFInterpolator

from adverbs.interp import bspline
from adverbs.verb.examples import examples_from_spec
from adverbs.verb.fit import build_from_examples, build_from_spec
from adverbs.verb.spec import load_spec


SPECS = Path(__file__).resolve().parent.parent / "specs"


def main() -> None:
    rows = []
    largest = "bandai_reach"
    spec = load_spec(SPECS / f"{largest}.toml")
    examples, adverbs = examples_from_spec(spec)
    build = median_seconds(lambda: build_from_examples(spec, examples, adverbs), 5)
    full = build_from_examples(spec, examples, adverbs)
    size = f"{len(examples)} examples, {full.encoding.num_dofs} DOFs, NumCP {full.num_cp}, goal chain"
    rows.append((f"build {full.name} ({size})", f"{build * 1e3:.0f} ms"))
    from_spec = median_seconds(lambda: build_from_spec(SPECS / f"{largest}.toml"), 3)
    rows.append((f"build {full.name} from its spec, reading and cutting the BVH files", f"{from_spec * 1e3:.0f} ms"))
    # The interpolation and sampling rows below, and scipy beside them, leave out the goal chain's solve (its own
    # rows come after): scipy answers the bare interpolation.
    verb = dataclasses.replace(full, goal_chain=())

    rng = np.random.default_rng(0)
    lo, hi = verb.points.min(axis=0), verb.points.max(axis=0)
    n = 3000
    p = rng.uniform(lo, hi, size=(n, len(lo)))
    clock = rng.uniform(0.0, 1.0, n) * verb.keytimes(p)[:, -1]
    def per_call(calls) -> float:
        times = []
        for call in calls:
            t0 = time.perf_counter()
            call()
            times.append(time.perf_counter() - t0)
        return statistics.median(times)

    state = verb.state()
    verb.pose(p[0], clock[0], state)  # compile (cached on disk after the first run)
    single = per_call([lambda k=k: verb.pose(p[k], clock[k], state) for k in range(n)])
    rows.append(("one pose at a new p every call (median)", f"{single * 1e6:.1f} µs"))
    cached = per_call([lambda k=k: verb.pose(p[0], clock[k], state) for k in range(n)])
    rows.append(("one pose, p unchanged (cached weights and keytimes, median)", f"{cached * 1e6:.1f} µs"))
    # Two creatures on one verb, each with its own state, evaluated alternately: the verb holds no cache.
    first, second = verb.state(), verb.state()
    calls = [lambda k=k: verb.pose(p[1], clock[k], first) if k % 2 else verb.pose(p[2], clock[k], second) for k in range(n)]
    alternate = per_call(calls)
    rows.append(("two creatures at different p, evaluated alternately (per call, median)", f"{alternate * 1e6:.1f} µs"))
    rows.append(("ratio alternating / one creature repeated", f"{alternate / cached:.2f}×"))

    crowd_p = rng.uniform(lo, hi, size=(10_000, len(lo)))
    crowd_clock = rng.uniform(0.0, 1.0, 10_000) * verb.keytimes(crowd_p)[:, -1]
    crowd = verb.state(10_000)
    verb.sample(crowd_p, crowd_clock, crowd)
    s_new = median_seconds(lambda: verb.sample(crowd_p, crowd_clock, verb.state(10_000)), 5)
    rows.append(("10,000 creatures, one frame, every p new (sample)", f"{s_new * 1e3:.1f} ms"))
    s_kept = median_seconds(lambda: verb.sample(crowd_p, crowd_clock, crowd), 5)
    rows.append(("10,000 creatures, one frame, p unchanged (sample, cached)", f"{s_kept * 1e3:.1f} ms"))

    q = rng.uniform(lo, hi, size=(10_000, len(lo)))
    t = rng.uniform(0.0, 1.0, 10_000)
    batch = median_seconds(lambda: verb.dofs(q, t), 7)
    rows.append(("10,000 (p, t) pairs in one batched call", f"{batch * 1e3:.1f} ms"))

    # The goal chain: an offset solved for each new adverb point (batched over the creatures whose point changed).
    state = full.state()
    full.pose(p[0], clock[0], state)
    goal_one = per_call([lambda k=k: full.pose(p[k], clock[k], state) for k in range(200)])
    rows.append(("with the goal chain: one pose at a new p every call (median)", f"{goal_one * 1e3:.2f} ms"))
    goal_p = crowd_p[:1000]
    goal_crowd = median_seconds(lambda: full.sample(goal_p, crowd_clock[:1000], full.state(1000)), 3)
    rows.append(("with the goal chain: 1,000 creatures, one frame, every p new", f"{goal_crowd * 1e3:.0f} ms"))
    kept = full.state(1000)
    full.sample(goal_p, crowd_clock[:1000], kept)
    goal_kept = median_seconds(lambda: full.sample(goal_p, crowd_clock[:1000], kept), 5)
    rows.append(("with the goal chain: 1,000 creatures, one frame, p unchanged", f"{goal_kept * 1e3:.2f} ms"))

    # scipy doing the same query: thin-plate RBF with a linear polynomial over all control points.
    scale = np.ptp(verb.points, axis=0)
    values = verb.coefficients.reshape(len(examples), -1)
    rbf = RBFInterpolator(verb.points / scale, values, kernel="thin_plate_spline", degree=1)

    def scipy_one(k):
        cp = rbf(p[k : k + 1] / scale)[0].reshape(verb.num_cp, -1)
        return bspline.evaluate(cp, np.array(0.5))

    times = []
    for k in range(300):
        t0 = time.perf_counter()
        scipy_one(k)
        times.append(time.perf_counter() - t0)
    scipy_single = statistics.median(times)
    rows.append(("scipy RBFInterpolator, one pose at a new p (median)", f"{scipy_single * 1e6:.1f} µs"))

    def scipy_batch():
        cps = rbf(q / scale).reshape(len(q), verb.num_cp, -1)
        idx, w = bspline.basis(t, verb.num_cp)
        return np.einsum("qk,qkd->qd", w, np.take_along_axis(cps, idx[:, :, None], axis=1))

    sb = median_seconds(scipy_batch, 3)
    rows.append(("scipy RBFInterpolator, 10,000 (p, t) pairs batched", f"{sb * 1e3:.1f} ms"))
    rows.append(("ratio scipy / ours, single pose", f"{scipy_single / single:.1f}×"))
    rows.append(("ratio scipy / ours, 10,000 batched", f"{sb / batch:.1f}×"))

    print_table("verb benchmark", rows)


if __name__ == "__main__":
    main()
