"""The README's pictures: a planted walk seen from the side, and what its toes do; a creature through a verb graph.

    .venv/bin/python docs/pictures.py        (writes docs/planted_walk.png and docs/graph_play.png)

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

from adverbs.graph import Cue, load_graph, perform  # noqa: E402
from adverbs.verb.fit import build_from_spec  # noqa: E402
from adverbs.feet.offline import plant_feet  # noqa: E402
from adverbs.feet.planter import effector_joints  # noqa: E402

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


def graph_play() -> None:
    """One creature through the Bandai graph on command: from above (its path, coloured by what plays), from
    the side (every fourth frame), and its toes' heights with the phases they are held."""
    graph = load_graph(ROOT / "graphs" / "bandai.toml")
    script = [Cue(0.5, "walk"), Cue(4.0, "run"), Cue(6.5, "walk"), Cue(8.5, "idle"), Cue(10.0, "bye")]
    perf = perform(graph, script, seconds=16.0, seed=3, adverbs={"valence": 0.4, "energy": 0.3, "turn": 20.0})
    pos = perf.planted.global_positions()
    body = graph.verbs[0].encoding.body_root
    colours = {name: f"C{i}" for i, name in enumerate(graph.verb_names)}
    blend = "0.55"
    which = [blend if "→" in w else colours[w.split(" at ")[0]] for w in perf.playing]
    fig, (top, side, toes) = plt.subplots(3, 1, figsize=(12, 10), gridspec_kw={"height_ratios": [1.2, 1, 0.8]})
    for f in range(1, len(pos)):
        top.plot(pos[f - 1 : f + 1, body, 0], pos[f - 1 : f + 1, body, 2], color=which[f], lw=2)
    for name in dict.fromkeys(w.split(" at ")[0] for w in perf.playing if "→" not in w):
        top.plot([], [], color=colours[name], lw=2, label=name)
    top.plot([], [], color=blend, lw=2, label="transition")
    for c in script:
        f = int(c.time * 30)
        top.annotate(f"{c.time:g} s: {c.verb}", pos[f, body, [0, 2]], fontsize=8, xytext=(4, 4), textcoords="offset points")
    top.set_aspect("equal")
    top.set_xlabel("x (m)")
    top.set_ylabel("z (m)")
    top.legend(fontsize=8, loc="best")
    top.set_title("Bandai graph, one creature on command (valence 0.4, turning 20 deg/s): the hips' path from above")
    parents = graph.skeleton.parents
    along = np.cumsum(np.r_[0.0, np.linalg.norm(np.diff(pos[:, body, [0, 2]], axis=0), axis=1)])
    for f in range(0, len(pos), 4):
        shift = along[f] - pos[f, body, 2]  # unrolled along the path, so turns do not overlap
        for j, parent in enumerate(parents):
            if parent >= 0 and j != body:
                side.plot(pos[f, [parent, j], 2] + shift, pos[f, [parent, j], 1], color=which[f], lw=0.6)
    side.axhline(0.0, color="k", lw=1)
    side.set_aspect("equal")
    side.set_xlabel("distance along the path (m)")
    side.set_ylabel("up (m)")
    side.set_title("from the side, every fourth frame (grey: blending two verbs)")
    verb = next(v for v in graph.verbs if v.holds)
    heights = [h.height for h in verb.holds]
    for i, (j, color) in enumerate(zip(effector_joints(verb), ("tab:blue", "tab:red"))):
        toes.plot(np.arange(len(pos)) / 30.0, 100 * (pos[:, j, 1] - heights[i]), color=color, label=graph.skeleton.names[j])
        for a, b in perf.report.phases[i]:
            toes.axvspan(a / 30.0, b / 30.0, ymin=0.02 + 0.05 * i, ymax=0.06 + 0.05 * i, color=color)
    toes.axhline(0.0, color="k", lw=0.6)
    toes.set_xlabel("seconds")
    toes.set_ylabel("toe above floor + contact (cm)")
    toes.legend(fontsize=8, loc="upper right")
    toes.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(ROOT / "docs" / "graph_play.png", dpi=80)


if __name__ == "__main__":
    main()
    graph_play()
