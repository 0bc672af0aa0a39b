"""The command line's run-time commands: ``adverbs run`` (a timed script through verb graphs), ``adverbs render``
(pictures of motion) and ``adverbs demo`` (the main job: the shipped graphs, a scenario, its files and pictures).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..errors import AdverbsError, AdverbsWarning
from ..graph import load_graph
from ..graph.structure import Graph
from ..io import read_motion
from ..io.files import write_atomic
from ..kinematics.floor import parse_floor
from ..runtime.script import load_script
from ..runtime.simulation import Simulation
from .render import CAMERAS, render
from .terminal import progress_bar

ROOT = Path(__file__).resolve().parents[3]
DEMO_SCRIPT = ROOT / "scripts" / "demo.toml"
RUN_SECONDS, RUN_FPS = 10.0, 30.0


def add_parsers(sub, positive, seed) -> None:
    """The ``run``, ``render`` and ``demo`` sub-commands."""
    p = sub.add_parser(
        "run", help="run creatures through verb graphs following a timed script; write BVH or glTF per creature and a log",
        description=(
            "Load the verb graphs (GRAPH, and any the script lists), add the script's creatures, and run them on "
            "the virtual clock (as fast as the machine goes, the same every time) or with --realtime on the wall "
            "clock; write OUT/NAME.bvh (or .glb, --format) per creature and OUT/events.json (the commands, transitions and refusals). "
            "A cue the graph refuses (an unknown verb or adverb, a value out of range) is reported and the run "
            "goes on; a malformed script is refused before the run, naming its line."
        ),
        epilog="Scripts: see scripts/demo.toml. Example: adverbs run graphs/bandai.toml --script scripts/demo.toml --out out/run",
    )  # fmt: skip
    p.add_argument("graphs", type=Path, nargs="*", metavar="GRAPH", help="graph specs (graphs/ has the shipped ones)")
    p.add_argument("--script", type=Path, required=True, help="the timed script (TOML)")
    p.add_argument("--out", type=Path, required=True, help="folder for the BVH files and events.json")
    p.add_argument("--realtime", action="store_true", help="run on the wall clock (the frame rate follows the load)")
    p.add_argument("--fps", type=positive, help=f"frame rate (default: the script's, else {RUN_FPS:g})")
    p.add_argument("--seed", type=seed, help="seeds the transitions drawn by likelihood (default: the script's, else 0)")
    p.add_argument("--seconds", type=positive, help=f"how long to run (default: the script's, else {RUN_SECONDS:g})")
    p.add_argument("--no-ik", action="store_true", help="do not plant the feet")
    p.add_argument("--floor", metavar="slope:DEGREES|flat:LEVEL|FILE", help="the ground feet are planted on (default flat at 0)")
    p.add_argument(
        "--format", type=_formats, default=("bvh",), metavar="bvh,glb",
        help="what to write per creature: bvh, glb (glTF 2.0 binary, for engines and the web) or both (default bvh)",
    )  # fmt: skip
    p.add_argument("--portable", action="store_true", help="BVH with position channels on the root only (three.js, pybvh)")

    p = sub.add_parser(
        "render", help="draw BVH motion as bones: an animated GIF or MP4, or a PNG filmstrip",
        description=(
            "Draw one or more BVH files as one scene (they play together from time 0): bones on a floor grid from "
            "a camera that follows them, feet on the ground marked, the root's path trailing. OUT's extension "
            "chooses: .gif or .mp4 (animated), .png (a filmstrip of evenly spaced frames)."
        ),
    )  # fmt: skip
    p.add_argument("motions", type=Path, nargs="+", metavar="MOTION.bvh")
    p.add_argument("-o", "--output", type=Path, required=True, metavar="OUT.gif|OUT.mp4|OUT.png")
    p.add_argument("--camera", default="three-quarter", help=f"{', '.join(CAMERAS)}, or AZIMUTH,ELEVATION in degrees")
    p.add_argument("--fps", type=positive, help="frames per second of an animation (default: the motion's, at most 30)")
    p.add_argument("--size", default="640x400", help="pixels, WIDTHxHEIGHT (a filmstrip panel is half that)")
    p.add_argument("--panels", type=int, default=8, help="frames in a filmstrip (default 8)")
    p.add_argument("--fixed", action="store_true", help="a fixed camera framing the whole motion, instead of following it")
    p.add_argument("--trail", type=float, default=4.0, help="seconds of root path shown (0: none; default 4)")
    p.add_argument("--split", action="store_true", help="each motion in its own view, side by side")
    p.add_argument(
        "--floor", metavar="slope:DEGREES|flat:LEVEL|FILE",
        help="the ground to draw, as given to synth or run (default level, at 0 or where the feet are)",
    )  # fmt: skip

    p = sub.add_parser(
        "demo", help="the main job: build the shipped graphs and play a scenario; write BVH, pictures and a report",
        description=(
            "Build the default verbs from the shipped capture, assemble the Bandai and CMU graphs and play the "
            "scenario of scripts/demo.toml (a Bandai creature stands, walks happily turning left, runs, walks "
            "sadly, reaches, bows and stands; a CMU creature walks, jogs and turns), with feet planted. Writes a "
            "BVH and a glTF file (.glb) per creature, events.json, an animated picture, a filmstrip and a report, and prints where."
        ),
    )  # fmt: skip
    p.add_argument("--out", type=Path, default=Path("out/demo"), help="where to write (default out/demo)")
    p.add_argument("--script", type=Path, default=DEMO_SCRIPT, help="the scenario (default scripts/demo.toml)")

    p = sub.add_parser(
        "view", help="a live web page: creatures on a graph, a slider per adverb, a button per verb",
        description=(
            "Serve a web page (viser) where creatures play a verb graph on the real-time clock: bones on a ground "
            "grid, planted feet marked, root trails; a slider per adverb (the examples' range and the graph's "
            "margin), a button per verb (through the planner), play/pause, speed, planted feet on/off, a command "
            "line (run, valence=0.5), what each creature plays and the frame rate. Open the printed address."
        ),
    )  # fmt: skip
    p.add_argument(
        "graph", type=Path, nargs="?", metavar="GRAPH|VERB",
        help="a graph spec (default graphs/bandai.toml), or one verb (a spec .toml or a built verb) played over and over",
    )  # fmt: skip
    p.add_argument("--creatures", type=int, default=1, help="how many creatures (default 1)")
    p.add_argument("--host", default="127.0.0.1", help="address to serve on (default 127.0.0.1: this machine only)")
    p.add_argument("--port", type=int, default=8080, help="port (default 8080)")
    p.add_argument("--fps", type=positive, help="the frame rate to aim at (default 60; it follows the load)")
    p.add_argument("--seed", type=seed, help="seeds the transitions drawn by likelihood (default 0)")
    p.add_argument("--no-ik", action="store_true", help="start with the feet not planted")


def _formats(text: str) -> tuple[str, ...]:
    kinds = tuple(k.strip().lower() for k in text.split(","))
    if not kinds or any(k not in ("bvh", "glb") for k in kinds):
        raise argparse.ArgumentTypeError(f"{text!r}: give bvh, glb or bvh,glb")
    return kinds


def _graphs(paths: Sequence[Path], progress: bool) -> list[Graph]:
    graphs: list[Graph] = []
    seen = set()
    for p in paths:
        key = Path(p).resolve()
        if key in seen:
            continue
        seen.add(key)
        if progress:
            print(f"loading graph {p}", file=sys.stderr)
        graphs.append(load_graph(p, progress=progress))
    if not graphs:
        raise AdverbsError("no graph: give one (GRAPH) or list them in the script (graphs = [...])")
    return graphs


def run_script(
    graphs: Sequence[Path], script_path: Path, out: Path, realtime: bool = False, fps: float | None = None,
    seed: int | None = None, seconds: float | None = None, plant: bool = True, floor=None, quiet: bool = False,
    formats: Sequence[str] = ("bvh",), portable: bool = False,
) -> tuple[Simulation, dict]:  # fmt: skip
    """Run a script; write the recordings and the log to ``out``. Returns the simulation and the paths written.

    Interrupted (Ctrl-C), it writes what was recorded up to then, says so, and raises the interrupt again."""
    if floor is not None and not plant:
        raise AdverbsError("--floor places the feet on the ground, but --no-ik leaves the feet where the verbs put them")
    if portable and "bvh" not in formats:
        raise AdverbsError(f"--portable is a kind of BVH, but --format writes only {', '.join(formats)}")
    script = load_script(script_path)  # a malformed script stops here, before anything is built
    loaded = _graphs([*graphs, *script.graphs], progress=not quiet)
    sim = Simulation(
        loaded, fps=fps or script.fps or RUN_FPS, seed=seed if seed is not None else (script.seed or 0), floor=floor,
        plant=plant, realtime=realtime,
    )  # fmt: skip
    script.apply(sim)
    length = seconds or script.seconds or RUN_SECONDS
    update, close = progress_bar("running") if not (quiet or realtime) else (None, lambda: None)
    try:
        sim.run(length, progress=update)
    except KeyboardInterrupt:
        close()
        if sim.frames:
            paths = sim.write(out, formats, portable)
            print(f"\ninterrupted at {sim.time:.1f} s of {length:g}: wrote what was recorded, {', '.join(map(str, paths.values()))}", file=sys.stderr)
        raise
    finally:
        close()
    return sim, sim.write(out, formats, portable)


def summary(sim: Simulation) -> list[str]:
    """Lines saying what each creature did: verbs played in order, transitions, refusals; and the frame rate."""
    lines = []
    for c in sim.creatures:
        verbs, transitions, refused = [], 0, []
        for e in sim.log:
            if e["creature"] != c.name:
                continue
            if e["command"] == "transition":
                transitions += 1
                if not verbs:
                    verbs.append(e["from"])
                if e["from"] != e["to"] and verbs[-1] != e["to"]:
                    verbs.append(e["to"])
            elif e["status"] == "refused":
                refused.append(f"{e['time']:g} s: {e['reason']}")
        lines.append(f"{c.name} ({c.graph.name}): {' → '.join(verbs) or c.verb}; {transitions} transitions, {sim.frames} frames")
        lines += [f"  {line}" for line in cue_lines(sim, c.name)]
    rate = sim.frames / sim.wall_seconds if sim.wall_seconds else float("nan")
    lines.append(f"{sim.frames} frames of {sim.time:.1f} s at {sim.fps:g} fps, computed at {rate:.0f} frames/s ({sim.clock.__class__.__name__})")
    return lines


def _asked(e: dict) -> str:
    """What a logged command asked, in words: its verb, or its adverbs."""
    if e["command"] == "perform":
        return str(e["verb"])
    return ", ".join(f"{k}={_value(v)}" for k, v in e["adverbs"].items())


def _value(v) -> str:
    """An adverb value as the log holds it (a number, or a refused value as its text: 'nan')."""
    return f"{v:g}" if isinstance(v, int | float) and not isinstance(v, bool) else str(v)


def cue_lines(sim: Simulation, creature: str) -> list[str]:
    """Every command given to ``creature``, a line each: its time, what it asked, what became of it (refused, adverbs
    set, its verb playing alone and when, superseded by a later one, not there by the end, or after the end)."""
    mine = [e for e in sim.log if e["creature"] == creature]
    out = []
    for i, e in enumerate(mine):
        if e["command"] not in ("perform", "adverbs"):
            continue
        what = _asked(e)
        if e["status"] == "refused":
            outcome = f"refused: {e['reason']}"
        elif e["command"] == "adverbs":
            outcome = f"adverbs eased in over {e['eased']:.2f} s" if e.get("eased") else "adverbs set"
        else:
            outcome = f"{e['verb']} not playing alone by the end"
            for later in mine[i + 1 :]:
                if later["command"] == "perform" and later["status"] == "ran":
                    outcome = f"superseded by the command at {later['time']:g} s before {e['verb']} played"
                    break
                if later["command"] == "arrived" and later["verb"] == e["verb"]:
                    outcome = f"{e['verb']} playing alone at {later['time']:.2f} s ({later['time'] - e['time']:.2f} s later)"
                    break
        out.append(f"{e['time']:7.2f} s  {what}: {outcome}")
    for e in sim.not_run():
        if e["creature"] == creature:
            out.append(f"{e['time']:7.2f} s  {_asked(e)}: {e['reason']}")
    return out


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(x) for x in text.lower().split("x"))
    except ValueError:
        raise AdverbsError(f"--size must be WIDTHxHEIGHT in pixels, e.g. 640x400, got {text!r}") from None
    return w, h


def _creature(key: str) -> str:
    """The creature a recording's key names (a second format's key is the creature's name and the format)."""
    return key.rsplit(".", 1)[0] if key.endswith((".bvh", ".glb")) else key


def main(args: argparse.Namespace) -> None:
    if args.command == "run":
        floor = parse_floor(args.floor) if args.floor else None
        sim, paths = run_script(
            args.graphs, args.script, args.out, args.realtime, args.fps, args.seed, args.seconds, not args.no_ik, floor,
            formats=args.format, portable=args.portable,
        )  # fmt: skip
        for line in summary(sim):
            print(line)
        for name, p in paths.items():
            print(f"wrote {p}" + ("" if name == "events" else f" (creature {_creature(name)})"))
    elif args.command == "render":
        clips = [read_motion(p) for p in args.motions]
        floor = parse_floor(args.floor) if args.floor else None
        update, close = progress_bar("drawing")
        try:
            out = render(
                clips, args.output, args.camera, args.fps, _size(args.size), args.panels, not args.fixed, args.trail,
                floor, split=args.split, progress=None if update is None else (lambda i, n: update(i, n)),
            )  # fmt: skip
        finally:
            close()
        print(f"wrote {out}")
    elif args.command == "demo":
        demo(args.out, args.script)
    elif args.command == "view":
        view(args)


def view(args: argparse.Namespace) -> None:
    """``adverbs view``: serve the page until interrupted."""
    from .viewer import Viewer, load_for_view

    if args.host not in ("127.0.0.1", "localhost", "::1"):
        print(f"adverbs: warning: serving on {args.host}: anyone who can reach this machine can open the page", file=sys.stderr)
    graphs = load_for_view(args.graph)
    viewer = Viewer(graphs, args.creatures, args.host, args.port, args.fps or 60.0, args.seed or 0, not args.no_ik).start()
    print(f"open {viewer.url} (Ctrl-C stops)", flush=True)
    try:
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        pass
    finally:
        viewer.stop()


def demo(out: Path, script: Path = DEMO_SCRIPT) -> dict[str, Path]:
    """The main job (see the ``demo`` command); returns what it wrote."""
    started = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)  # the verbs' build notes: the report says what matters
        sim, paths = run_script([], script, out, formats=("bvh", "glb"))
    clips = [c.clip() for c in sim.creatures]
    update, close = progress_bar("drawing")
    try:
        paths["animation"] = render(clips, out / "demo.gif", fps=10, size=(960, 420), split=True, progress=update)
    finally:
        close()
    at = _panel_times(sim, sim.creatures[0].name)
    paths["filmstrip"] = render(clips, out / "demo.png", size=(400, 360), split=True, at=at)
    report = {"summary": summary(sim), "feet": _feet(sim, clips), **sim.report()}
    write_atomic(out / "report.json", (json.dumps(report, indent=1) + "\n").encode())
    paths["report"] = out / "report.json"
    print()
    for line in report["summary"]:
        print(line)
    for c, f in report["feet"].items():
        print(f"{c}: feet {f}")
    print(f"\ndone in {time.perf_counter() - started:.0f} s; wrote:")
    for name, p in paths.items():
        print(f"  {p}" + ("" if name in ("events", "animation", "filmstrip", "report") else f"  (creature {_creature(name)})"))
    return paths


def _panel_times(sim: Simulation, creature: str, panels: int = 8) -> list[float]:
    """A filmstrip's panel times that show every verb ``creature`` was told to perform: the start, each commanded
    verb a second after it came to play alone (or halfway to the next, if sooner), the end; evenly spaced when
    there are more verbs than panels."""
    arrived = [e["time"] for e in sim.log if e["creature"] == creature and e["command"] == "arrived"]
    ends = arrived[1:] + [sim.time]
    shown = [min(t + 1.0, 0.5 * (t + end)) for t, end in zip(arrived, ends)]
    if len(shown) > panels - 2:
        return list(np.linspace(0.0, sim.time, panels))
    return [0.0, *shown, sim.time]


def _feet(sim: Simulation, clips: list) -> dict[str, str]:
    """For each creature, what its feet did, measured on its recording over the phases the planter held them
    (:func:`~adverbs.feet.measures.measure_feet`: held toes' drift, the lowest toe against the floor, ...)."""
    from ..feet.measures import measure_feet

    out = {}
    for c, clip in zip(sim.creatures, clips):
        holding = next((v for v in c.graph.verbs if v.holds), None)
        report = c.holds()
        if holding is None or report is None:
            out[c.name] = "feet not planted"
            continue
        metrics = measure_feet(holding, clip, report, sim.floor)
        out[c.name] = metrics.line() if len(metrics.toe_drift) else "no foot was held"
    return out
