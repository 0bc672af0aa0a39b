"""Figures of a verb's adverb space, like the paper's: ``adverbs figure VERB --axes A B -o out.png``.

* ``--kind poses`` (default): a grid of poses sampled across two adverbs (the others at the examples' mean), each
  drawn where its adverbs put it, seen from the side (facing right), the examples' own poses over them in another
  colour (the paper's Figures 3–4). The pose is the verb's at its middle keytime (a reach at its peak).
* ``--kind space``: the examples as points in the two adverbs, with one example's cardinal weight as a heat map —
  1 at that example, 0 at the others, and how far its influence reaches between and beyond them.
* ``--kind feet``: three cycles at the examples' mean (or at ``point``), each constrained foot's toe from above and
  its height over time, with planted feet (solid) and without IK (dotted), the floor at 0: what planting changes.
* ``--kind run`` (for a run's folder or its ``events.json``, from ``adverbs run --out DIR`` or the demo): each
  creature's root path from above, coloured by the verb it plays (a blend shades from one verb's colour to the
  next), and a timeline of the verbs per creature.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import AdverbsError
from ..io.files import atomic_path
from ..kinematics.fk import forward_kinematics
from ..verb.tables import Verb

KINDS = ("poses", "space", "feet", "run")
EXAMPLE_COLOR, GRID_COLOR = "#d9480f", "#1c7ed6"


def _axes(verb: Verb, axes: tuple[str, str]) -> tuple[int, int]:
    if len(axes) != 2 or axes[0] == axes[1]:
        raise AdverbsError(f"--axes needs two different adverbs, got {list(axes)}")
    for a in axes:
        if a not in verb.adverb_names:
            raise AdverbsError(f"verb {verb.name!r} has no adverb {a!r}; its adverbs are {', '.join(verb.adverb_names)}")
    return verb.adverb_names.index(axes[0]), verb.adverb_names.index(axes[1])


def _grid(verb: Verb, ia: int, ib: int, n: int, margin: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Adverb points ``(n·n, A)`` over the examples' span of adverbs ``ia`` and ``ib`` (widened by ``margin`` of it),
    the others at the examples' mean; and the two axes' values."""
    lo, hi = verb.points.min(axis=0), verb.points.max(axis=0)
    span = hi - lo
    a = np.linspace(lo[ia] - margin * span[ia], hi[ia] + margin * span[ia], n)
    b = np.linspace(lo[ib] - margin * span[ib], hi[ib] + margin * span[ib], n)
    points = np.tile(verb.points.mean(axis=0), (n * n, 1))
    aa, bb = np.meshgrid(a, b)
    points[:, ia], points[:, ib] = aa.ravel(), bb.ravel()
    return points, a, b


def _poses(verb: Verb, points: np.ndarray) -> np.ndarray:
    """World joint positions ``(Q, J, 3)`` at adverb points ``points (Q, A)``, at the verb's middle keytime, the root
    at the origin facing +Z."""
    g = float(verb.generic_keytimes[len(verb.generic_keytimes) // 2])
    dofs = verb.dofs(points, np.full(len(points), g))
    rot, trans = verb.encoding.decode_pose(dofs, np.zeros((len(points), 3)))
    return forward_kinematics(verb.skeleton.parents, rot, trans)[0]


def figure(
    verb: Verb, axes: tuple[str, str] | None, output: str | Path, kind: str = "poses", n: int = 5, example: int = 0,
    point: np.ndarray | None = None,
) -> Path:  # fmt: skip
    """Draw ``kind`` (see the module) over adverbs ``axes`` of ``verb`` to ``output`` (.png, .pdf or .svg)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if kind not in KINDS:
        raise AdverbsError(f"--kind {kind!r}: use one of {', '.join(KINDS)}")
    if not (isinstance(n, int) and 2 <= n <= 12):
        raise AdverbsError(f"--size must be a whole number from 2 to 12, got {n!r}")
    output = Path(output)
    if kind == "run":
        raise AdverbsError("--kind run draws a run: give the run's folder or its events.json instead of a verb")
    if kind == "feet":
        fig = _feet(verb, verb.points.mean(axis=0) if point is None else verb.point(point), plt)
        return save_figure(fig, output, plt)
    if axes is None and len(verb.adverb_names) == 2:
        axes = tuple(verb.adverb_names)  # the only two there are
    if axes is None:
        raise AdverbsError(f"--kind {kind} needs --axes A B: two of {', '.join(verb.adverb_names)}")
    ia, ib = _axes(verb, axes)
    fig, ax = plt.subplots(figsize=(8, 7))
    if kind == "poses":
        points, a, b = _grid(verb, ia, ib, n)
        da, db = (a[1] - a[0]) or 1.0, (b[1] - b[0]) or 1.0
        grid, examples = _poses(verb, points), _poses(verb, verb.points)
        height = np.ptp(np.concatenate([grid, examples])[..., 1])
        scale = 0.85 / height  # square cells, one per grid point: a figure is 0.85 of a cell tall, true to shape
        parents = verb.skeleton.parents
        body = verb.skeleton.body_root()

        def draw(pos: np.ndarray, at: np.ndarray, color: str, width: float) -> None:
            cell = ((at[0] - a[0]) / da, (at[1] - b[0]) / db)
            x = (pos[:, 2] - pos[body, 2]) * scale + cell[0]  # side view: forward (+z) to the right, y up
            y = (pos[:, 1] - pos[:, 1].min() - 0.5 * height) * scale + cell[1]
            for j in range(1, len(parents)):
                ax.plot([x[parents[j]], x[j]], [y[parents[j]], y[j]], color=color, lw=width, solid_capstyle="round")

        for pos, p in zip(grid, points):
            draw(pos, p[[ia, ib]], GRID_COLOR, 1.2)
        for pos, p in zip(examples, verb.points):
            draw(pos, p[[ia, ib]], EXAMPLE_COLOR, 1.0)
        ax.set_aspect("equal")
        ax.set_xlim(-0.6, n - 0.4)
        ax.set_ylim(-0.6, n - 0.4)
        ax.set_xticks(range(n), [f"{x:.3g}" for x in a])
        ax.set_yticks(range(n), [f"{x:.3g}" for x in b])
        ax.set_title(f"{verb.name}: poses across {axes[0]} and {axes[1]} (blue), the examples (orange)")
    else:
        if not 0 <= example < len(verb.examples):
            raise AdverbsError(f"--example {example}: the verb has examples 0 to {len(verb.examples) - 1}")
        points, a, b = _grid(verb, ia, ib, 60, margin=0.25)
        w = verb.weights(points)[:, example].reshape(len(b), len(a))
        limit = max(1.0, float(np.abs(w).max()))
        mesh = ax.pcolormesh(a, b, w, cmap="RdBu_r", vmin=-limit, vmax=limit, shading="auto")
        fig.colorbar(mesh, ax=ax, label=f"weight of example {verb.examples[example].name!r}")
        ax.scatter(verb.points[:, ia], verb.points[:, ib], c="k", s=18, zorder=3)
        ax.scatter(verb.points[example, ia], verb.points[example, ib], facecolors="none", edgecolors="k", s=140, zorder=3)
        ax.set_title(f"{verb.name}: the examples in adverb space, one example's cardinal weight")
    ax.set_xlabel(axes[0])
    ax.set_ylabel(axes[1])
    return save_figure(fig, output, plt)


def _feet(verb: Verb, point: np.ndarray, plt):
    """Toe paths from above and toe heights over time, planted and not (see the module)."""
    from ..feet.offline import plant_feet

    if not verb.constraints:
        raise AdverbsError(f"verb {verb.name!r} has no constraints: no feet to plant")
    clip, k = verb.synthesize(point, cycles=3 if verb.cyclic else None)
    planted, _ = plant_feet(verb, clip, k, None, point)
    toes = [verb.skeleton.index(c.effector) for c in verb.constraints]
    free, held = clip.global_positions()[:, toes], planted.global_positions()[:, toes]
    t = np.arange(clip.num_frames) / clip.fps
    fig, (top, side) = plt.subplots(1, 2, figsize=(11, 4.5), gridspec_kw={"width_ratios": [1, 1.6]})
    for i, c in enumerate(verb.constraints):
        color = f"C{i}"
        top.plot(free[:, i, 0], free[:, i, 2], ":", color=color, lw=1)
        top.plot(held[:, i, 0], held[:, i, 2], "-", color=color, lw=1.5, label=c.effector)
        side.plot(t, free[:, i, 1], ":", color=color, lw=1, label=f"{c.effector}, no IK")
        side.plot(t, held[:, i, 1], "-", color=color, lw=1.5, label=f"{c.effector}, planted")
    side.axhline(0.0, color="k", lw=0.8)
    top.set_aspect("equal", adjustable="datalim")
    top.set_xlabel("x (m)")
    top.set_ylabel("z (m)")
    top.set_title("toes from above")
    top.legend(fontsize=8)
    side.set_xlabel("time (s)")
    side.set_ylabel("toe joint height (m)")
    side.set_title("toe heights: planted (solid), no IK (dotted); the floor at 0")
    side.legend(fontsize=8, ncol=2)
    values = ", ".join(f"{a}={x:.3g}" for a, x in zip(verb.adverb_names, point))
    fig.suptitle(f"{verb.name} at {values}")
    return fig


def is_run(path: str | Path) -> bool:
    """Whether ``path`` names a run (a folder, or a ``.json`` log) rather than a verb."""
    path = Path(path)
    return path.is_dir() or path.suffix.lower() == ".json"


def timeline(entries: list[dict], start_verb: str) -> list[tuple[float, str, str, float]]:
    """A creature's verb changes ``(time, from, to, blend seconds)`` in time order, from its transition log entries;
    loops of a verb into itself are left out (the verb goes on)."""
    changes = []
    for e in sorted(entries, key=lambda e: e["time"]):
        if e["from"] != e["to"]:
            changes.append((float(e["time"]), str(e["from"]), str(e["to"]), float(e.get("seconds", 0.0))))
    if not changes:
        return [(-np.inf, start_verb, start_verb, 0.0)]
    return [(-np.inf, changes[0][1], changes[0][1], 0.0), *changes]


def shade(t: np.ndarray, line: list[tuple[float, str, str, float]], color: dict[str, np.ndarray]) -> np.ndarray:
    """The colour ``(len(t), 3)`` at each time of a creature's timeline (:func:`timeline`): the playing verb's,
    shading linearly from the old verb's to the new one's over a blend (its β)."""
    k = np.searchsorted([x[0] for x in line], t, side="right") - 1
    out = np.empty((len(t), 3))
    for i, (t0, a, b, blend) in enumerate(line):
        rows = k == i
        u = np.clip((t[rows] - t0) / blend, 0.0, 1.0)[:, None] if blend > 0 else np.ones((rows.sum(), 1))
        out[rows] = (1 - u) * color[a] + u * color[b]
    return out


def run_figure(run: str | Path, output: str | Path) -> Path:
    """Draw a run (``--kind run``, see the module) from its folder or ``events.json`` and the creatures' recordings
    beside it (``NAME.bvh`` or ``NAME.glb``) to ``output``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection
    from matplotlib.colors import to_rgb

    from ..io import read_motion

    run = Path(run)
    log = run / "events.json" if run.is_dir() else run
    try:
        report = json.loads(log.read_text())
        creatures, events = report["creatures"], report["events"]
        names = [str(c["name"]) for c in creatures]
    except FileNotFoundError:
        raise AdverbsError(f"{log}: no such file (a run's folder holds events.json: adverbs run --out DIR)") from None
    except (OSError, UnicodeDecodeError, ValueError, KeyError, TypeError) as e:
        raise AdverbsError(f"{log}: not a run log (events.json from adverbs run): {e!r}") from None
    if not creatures:
        raise AdverbsError(f"{log}: the run has no creatures")
    paths, times, lines = [], [], []
    for c in creatures:
        found = [log.parent / f"{c['name']}{ext}" for ext in (".bvh", ".glb")]
        found = [p for p in found if p.exists()]
        if not found:
            raise AdverbsError(f"{log}: creature {c['name']!r} has no recording beside it ({c['name']}.bvh or .glb)")
        clip = read_motion(found[0])
        body = clip.skeleton.body_root()
        paths.append(clip.global_positions()[:, body])
        first = c.get("recorded_from")
        times.append((0.0 if first is None else float(first)) + np.arange(clip.num_frames) / clip.fps)
        mine = [e for e in events if e.get("creature") == c["name"] and e.get("command") == "transition"]
        lines.append(timeline(mine, str(c.get("verb", "?"))))
    verbs = list(dict.fromkeys(v for line in lines for _, a, b, _ in line for v in (a, b)))
    palette = plt.get_cmap("tab10" if len(verbs) <= 10 else "tab20")
    color = {v: np.array(to_rgb(palette(i % palette.N))) for i, v in enumerate(verbs)}

    fig, (top, when) = plt.subplots(
        2, 1, figsize=(9, 8.5), gridspec_kw={"height_ratios": [3.2, 0.45 + 0.35 * len(names)]}
    )  # fmt: skip
    for name, pos, t, line in zip(names, paths, times, lines):
        xy = pos[:, [0, 2]]
        if len(xy) > 1:
            segments = np.stack([xy[:-1], xy[1:]], axis=1)
            top.add_collection(LineCollection(segments, colors=shade(t[:-1], line, color), linewidths=2.4))
        top.plot(*xy[0], "o", color="k", ms=5)
        top.plot(*xy[-1], "s", color="k", ms=5)
        top.annotate(name, xy[0], textcoords="offset points", xytext=(6, 6), fontsize=9)
        for t0, *_ in line[1:]:
            i = min(int(np.searchsorted(t, t0)), len(xy) - 1)
            top.plot(*xy[i], "|", color="k", ms=9, mew=1)
    top.autoscale()
    top.set_aspect("equal", adjustable="datalim")
    top.set_xlabel("x (m)")
    top.set_ylabel("z (m)")
    top.set_title("root paths from above, coloured by verb (start ●, end ■, | where a verb change begins)")
    top.legend(
        handles=[plt.Line2D([], [], color=color[v], lw=3, label=v) for v in verbs], fontsize=8, loc="best", ncol=2
    )  # fmt: skip
    end = max(float(t[-1]) for t in times)
    for row, (t, line) in enumerate(zip(times, lines)):
        grid = np.linspace(float(t[0]), float(t[-1]), 600)
        when.imshow(
            shade(grid, line, color)[None], extent=(grid[0], grid[-1], row + 0.35, row - 0.35), aspect="auto",
            interpolation="nearest",
        )  # fmt: skip
    when.set_yticks(range(len(names)), names)
    when.set_ylim(len(names) - 0.5, -0.5)
    when.set_xlim(0.0, end)
    when.set_xlabel("time (s)")
    when.set_title("verbs over time")
    return save_figure(fig, Path(output), plt)


def save_figure(fig, output: Path, plt) -> Path:
    """Lay out ``fig``, write it to ``output`` whole or not at all (the file type by its extension), and close it."""
    fig.tight_layout()
    try:
        with atomic_path(output) as tmp:
            fig.savefig(tmp, dpi=110)
    finally:
        plt.close(fig)
    return output
