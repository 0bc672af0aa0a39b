"""Planted-feet benchmarks: IK for two feet, one creature and a crowd; the online planter one frame at a
time for 1,000 creatures; what planted feet look like on the shipped walks and runs.

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
from adverbs.feet.measures import foot_drift, measure_feet
from adverbs.feet.offline import plant_feet_many
from adverbs.feet.planter import FootPlanter, effector_joints, frame_generic
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
    for crowd in (1, 1000):
        pts = rng.uniform(lo, hi, size=(crowd, len(lo)))
        clips = [verb.synthesize(p, duration=1.0) for p in pts]
        rot_f = np.stack([c.rotations[:30] for c, _ in clips], axis=1)
        trans_f = np.stack([c.translations[:30] for c, _ in clips], axis=1)
        gen = np.stack([frame_generic(verb, k, np.arange(30) / verb.fps) for _, k in clips], axis=1)

        for compiled in (True, False):

            def online(rot_f=rot_f, trans_f=trans_f, gen=gen, pts=pts, crowd=crowd, compiled=compiled):
                planter = FootPlanter(verb, crowd, slope, verb.weights(pts), compiled=compiled)
                for f in range(len(gen)):
                    planter.step(rot_f[f], trans_f[f], gen[f], 1.0 / verb.fps)

            s = median_seconds(online, 3)
            rows.append(
                (
                    f"FootPlanter.step{'' if compiled else '_reference (NumPy)'}, {crowd:,} "
                    f"creature{'s' if crowd > 1 else ''} on a slope, one frame at a time "
                    "(state, FK, targets, IK; per creature-frame)",
                    f"{s * 1e6 / (crowd * len(gen)):.1f} µs",
                )
            )
    r, t, x = rot[:200], trans[:200], targets[:200]
    s = median_seconds(lambda: ik.solve_reference(chains, r, t, x), 5)
    rows.append(("NumPy reference solver, 200 creatures (per creature-frame)", f"{s * 1e6 / 200:.1f} µs"))
    print_table("planted feet: speed", rows)
    print()

    rows = []
    for name in ("cmu_walk", "bandai_styled_walk", "cmu_run", "bandai_run"):
        verb = build_from_spec(SPECS / f"{name}.toml")
        for kind, pts in obedience_points(verb).items():
            motions = [(*verb.synthesize(p, cycles=3), p) for p in pts]
            raw = np.concatenate([foot_drift(verb, c, k, verb.weights(p)) for c, k, p in motions])
            for floor_name, floor in (("flat", None), ("10° slope", slope)):
                ms = [
                    measure_feet(verb, done, report, floor, c)
                    for (c, _, _), (done, report) in zip(motions, plant_feet_many(verb, motions, floor))
                ]
                toe = 1000 * np.concatenate([m.toe_drift for m in ms])
                slides = np.concatenate([m.slide for m in ms])
                own = np.concatenate([m.free_slide for m in ms])
                rows.append(
                    (
                        f"{verb.name}, {kind}, {floor_name}",
                        f"{np.median(toe):.1f} / {toe.max():.1f}",
                        f"{1000 * max(m.heel_drift.max(initial=0) for m in ms):.1f}",
                        f"{1000 * min(m.lowest for m in ms):+.1f}",
                        f"{1000 * max(m.held_height for m in ms):.1f}",
                        f"{1000 * slides.max():.1f} ({int((own > 0.01).sum())}/{len(own)}, {1000 * own.max():.0f})",
                        f"{sum(m.unreachable for m in ms)}",
                        f"{np.median(1000 * raw):.0f} / {1000 * raw.max():.0f}",
                    )
                )
    header = (
        "3 cycles at every obedience point", "toe drift, mm (median / max)", "heel drift while flat, max mm",
        "lowest toe vs floor + contact, mm", "held toe height error, max mm",
        "slide after release, max mm (releases where the verb's own toe skims; its own slide, max mm)",
        "effector-frames out of reach",
        "toe drift without IK, mm",
    )  # fmt: skip
    print_table(header, rows)


if __name__ == "__main__":
    main()
