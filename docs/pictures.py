"""The README's picture: a planted walk seen from the side, and what its toes do.

    .venv/bin/python docs/pictures.py        (writes docs/planted_walk.png)

Top: the CMU walk at an adverb point between its examples (1.45 m/s), three cycles, every third frame,
planted on flat ground; left limbs blue, right red. Bottom: each toe joint's height over the floor plus
its contact height, planted (solid) and as the verb alone puts it (dotted), with the phases where the
ball is held (dark bars) and the foot is flat (light bars).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from adverbs.verb.fit import build_from_spec  # noqa: E402
from adverbs.verb.planting import effector_joints, plant_feet  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    verb = build_from_spec(ROOT / "specs" / "cmu_walk.toml")
    p = verb.point({"speed": 1.45, "turn": 0.0})
    clip, k = verb.synthesize(p, cycles=3)
    planted, report = plant_feet(verb, clip, k, None, p)
    pos, free = planted.global_positions(), clip.global_positions()
    tips = effector_joints(verb)
    height = np.array([h.height for h in verb.holds])
    parents = verb.skeleton.parents
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(12, 6.5), gridspec_kw={"height_ratios": [1.3, 1]})
    for f in range(0, planted.num_frames, 3):
        for j, parent in enumerate(parents):
            if parent < 0:
                continue
            color = {"left": "tab:blue", "right": "tab:red"}.get(verb.skeleton.side(j), "0.3")
            top.plot(pos[f, [parent, j], 2], pos[f, [parent, j], 1], color=color, lw=0.8, alpha=0.8)
    top.axhline(verb.floor, color="k", lw=1)
    top.set_aspect("equal")
    top.set_xlabel("forward (m)")
    top.set_ylabel("up (m)")
    top.set_title(f"{verb.name} at speed {p[0]:.2f} m/s, turn {p[1]:.0f} deg/s: planted, every third frame")
    frames = np.arange(planted.num_frames)
    for i, color in enumerate(("tab:blue", "tab:red")):
        side = "left" if i == 0 else "right"
        bottom.plot(frames, 100 * (pos[:, tips[i], 1] - verb.floor - height[i]), color=color, label=f"{side} toe, planted")
        bottom.plot(frames, 100 * (free[:, tips[i], 1] - verb.floor - height[i]), ":", color=color, label=f"{side} toe, verb alone")
        for a, b in report.phases[i]:
            bottom.axvspan(a - 0.5, b - 0.5, ymin=0.02 + 0.05 * i, ymax=0.05 + 0.05 * i, color=color)
        for a, b in report.flat[i]:
            bottom.axvspan(a - 0.5, b - 0.5, ymin=0.12 + 0.05 * i, ymax=0.15 + 0.05 * i, color=color, alpha=0.35)
    bottom.axhline(0.0, color="k", lw=0.6)
    bottom.set_ylim(-2, 14)
    bottom.set_xlabel("frame (30 fps)")
    bottom.set_ylabel("toe above floor + contact (cm)")
    bottom.legend(ncol=4, fontsize=8, loc="upper right")
    bottom.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(ROOT / "docs" / "planted_walk.png", dpi=90)


if __name__ == "__main__":
    main()
