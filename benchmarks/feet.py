"""Planted-feet benchmarks: IK for two feet, one creature and a crowd; drift with and without IK.

    make bench            (or: .venv/bin/python benchmarks/feet.py)

Prints Markdown tables; medians of repeated runs on this machine.
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path

import numpy as np
from timing import median_seconds, print_table

from adverbs import ik
from adverbs.apps.evaluate import obedience_points
from adverbs.kinematics.floor import SlopeFloor, tilt
from adverbs.verb.planting import effector_joints, foot_drift, plant_feet, plant_feet_many
from adverbs.verb.fit import build_from_spec

SPECS = Path(__file__).resolve().parent.parent / "specs"


def main() -> None:
    rows = []
    verb = build_from_spec(SPECS / "bandai_styled_walk.toml")
    chains = verb.leg_chains
    rng = np.random.default_rng(0)
    lo, hi = verb.points.min(axis=0), verb.points.max(axis=0)
    # Poses from the verb at many adverb points and phases, targets a few centimetres off the verb's feet.
    poses = [verb.synthesize(p, cycles=1) for p in rng.uniform(lo, hi, size=(40, len(lo)))]
    rot = np.concatenate([c.rotations for c, _ in poses])
    trans = np.concatenate([c.translations for c, _ in poses])
    feet = np.concatenate([c.global_positions()[:, effector_joints(verb)] for c, _ in poses])
    targets = feet + rng.normal(scale=0.02, size=feet.shape)
    slope = SlopeFloor(10.0)
    tilts = tilt(slope.normal(targets[..., [0, 2]]))
    ik.solve(chains, rot[:2], trans[:2], targets[:2])  # compile (cached on disk after the first run)

    times = []
    for f in range(min(len(rot), 2000)):
        t0 = time.perf_counter()
        ik.solve(chains, rot[f], trans[f], targets[f], tilts[f])
        times.append(time.perf_counter() - t0)
    rows.append(
        ("IK for two feet, one creature (per creature-frame, median)", f"{statistics.median(times) * 1e6:.1f} µs")
    )
    for crowd in (1000, 10_000):
        pick = rng.integers(0, len(rot), crowd)
        r, t, x, g = rot[pick], trans[pick], targets[pick], tilts[pick]
        s = median_seconds(lambda r=r, t=t, x=x, g=g: ik.solve(chains, r, t, x, g), 5)
        rows.append(
            (f"IK for two feet, {crowd:,} creatures in one call (per creature-frame)", f"{s * 1e6 / crowd:.2f} µs")
        )
    motions = [verb.synthesize(p, cycles=2) for p in rng.uniform(lo, hi, size=(200, len(lo)))]
    frames = sum(c.num_frames for c, _ in motions)
    s = median_seconds(lambda: plant_feet_many(verb, motions, slope), 3)
    rows.append(
        (
            "plant_feet_many: 200 creatures × 2 cycles on a slope, all of it (per creature-frame)",
            f"{s * 1e6 / frames:.1f} µs",
        )
    )
    r, t, x = rot[:200], trans[:200], targets[:200]
    s = median_seconds(lambda: ik.solve_reference(chains, r, t, x), 5)
    rows.append(("NumPy reference solver, 200 creatures (per creature-frame)", f"{s * 1e6 / 200:.1f} µs"))
    print_table("planted feet: speed", rows)
    print()

    rows = []
    for name in ("cmu_walk", "bandai_styled_walk"):
        verb = build_from_spec(SPECS / f"{name}.toml")
        for kind, pts in obedience_points(verb).items():
            raw, held, slope_held = [], [], []
            for p in pts:
                clip, k = verb.synthesize(p, cycles=2)
                raw.append(foot_drift(verb, clip, k))
                held.append(foot_drift(verb, plant_feet(verb, clip, k)[0], k))
                slope_held.append(foot_drift(verb, plant_feet(verb, clip, k, slope)[0], k))
            raw, held, slope_held = (1000 * np.concatenate(x) for x in (raw, held, slope_held))
            rows.append(
                (
                    f"{verb.name}, {kind} ({len(pts)} points, {len(held)} phases)",
                    f"{np.median(held):.2f} / {held.max():.2f}",
                    f"{np.median(slope_held):.2f} / {slope_held.max():.2f}",
                    f"{np.median(raw):.1f} / {raw.max():.1f}",
                )
            )
    header = ("planted-foot drift per contact phase, mm (median / max)", "IK, flat", "IK, 10° slope", "no IK")
    print_table(header, rows)


if __name__ == "__main__":
    main()
