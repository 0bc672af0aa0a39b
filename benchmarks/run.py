"""Benchmarks on the shipped clips; prints a Markdown table.

    make bench            (or: .venv/bin/python benchmarks/run.py)

Each figure is the median of several timed repeats on this machine.
"""

from __future__ import annotations

import platform
import tempfile
from pathlib import Path

import numpy as np
from timing import median_seconds, print_table

from adverbs import forward_kinematics, read_bvh, write_bvh
from adverbs.motion.encoding import DofEncoding

DATA = Path(__file__).resolve().parent.parent / "data"


def main() -> None:
    rows = []
    for source in ("cmu16", "bandai", "reactidle"):
        files = sorted((DATA / source).glob("*.bvh"))
        size = sum(f.stat().st_size for f in files)
        t = median_seconds(lambda files=files: [read_bvh(f) for f in files], repeats=5)
        rows.append((f"BVH read, {source} ({len(files)} files, {size / 1e6:.1f} MB)", f"{size / 1e6 / t:.1f} MB/s"))
    # The writer on a long clip (issue 14: 108,000 frames once took 33 s): the CMU walk repeated to 100,000 frames.
    walk = read_bvh(DATA / "cmu16" / "16_15_walk.bvh")
    reps = -(-100_000 // walk.num_frames)
    long = walk.replace(rotations=np.tile(walk.rotations, (reps, 1, 1))[:100_000], translations=np.tile(walk.translations, (reps, 1, 1))[:100_000])
    with tempfile.TemporaryDirectory() as tmp:
        t = median_seconds(lambda: write_bvh(long, Path(tmp) / "long.bvh"), repeats=3)
    rows.append((f"BVH write, 100,000 frames of {walk.skeleton.num_joints} joints", f"{t:.2f} s ({100_000 / t:,.0f} frames/s)"))

    for name in ("cmu16/16_15_walk.bvh", "bandai/dataset-1_walk_sad_001.bvh"):
        clip = read_bvh(DATA / name)
        parents = clip.skeleton.parents
        t = median_seconds(
            lambda clip=clip: forward_kinematics(clip.skeleton.parents, clip.rotations, clip.translations)
        )
        rows.append(
            (
                f"FK one clip, {name} ({clip.num_frames} frames, {clip.skeleton.num_joints} joints)",
                f"{clip.num_frames / t:,.0f} frames/s",
            )
        )
        batch = 10_000 // clip.num_frames + 1
        rot = np.broadcast_to(clip.rotations, (batch,) + clip.rotations.shape)
        trans = np.broadcast_to(clip.translations, (batch,) + clip.translations.shape)
        t = median_seconds(
            lambda parents=parents, rot=rot, trans=trans: forward_kinematics(parents, rot, trans), repeats=5
        )
        rows.append(
            (
                f"FK batched, {batch} × {name} ({batch * clip.num_frames} frames)",
                f"{batch * clip.num_frames / t:,.0f} frames/s",
            )
        )
        t = median_seconds(
            lambda clip=clip: forward_kinematics(clip.skeleton.parents, clip.rotations[0], clip.translations[0]),
            repeats=200,
        )
        rows.append((f"FK one pose, {name}", f"{t * 1e6:.0f} µs"))
        enc = DofEncoding.fit(clip)
        d = enc.encode(clip)
        t = median_seconds(lambda enc=enc, clip=clip: enc.encode(clip))
        rows.append((f"encode to log-quaternion DOFs, {name}", f"{clip.num_frames / t:,.0f} frames/s"))
        t = median_seconds(lambda enc=enc, d=d, clip=clip: enc.decode(d, clip.fps))
        rows.append((f"decode DOFs, {name}", f"{clip.num_frames / t:,.0f} frames/s"))

    print(
        f"Machine: {platform.processor() or platform.machine()}, Python {platform.python_version()}, "
        f"NumPy {np.__version__}\n"
    )
    print_table("what", rows)


if __name__ == "__main__":
    main()
