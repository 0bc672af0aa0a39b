"""The ``adverbs`` command line: how people and scripts drive the library.

    adverbs info FILE.bvh [--json]
    adverbs convert IN.bvh|IN.glb OUT.bvh|OUT.glb [--portable] [--fps F] [--mirror] [--frames A:B]
    adverbs build SPEC.toml -o VERB
    adverbs describe VERB [--json]
    adverbs synth VERB --adverb NAME=VALUE ... [--cycles N | --duration S] [--fps F]
                  [--no-ik] [--method M] [--clamp [MARGIN]] [--floor slope:DEGREES | FILE.npz]
                  -o OUT.bvh|OUT.glb [--portable]
    adverbs evaluate VERB [--png PLOT.png] [--json]
    adverbs heldout [--data DIR] [--split odd-even|even-odd|leave-one-out]
    adverbs figure VERB [--axes A B] -o OUT.png [--kind poses|space|feet] [--size N] [--example K]
    adverbs figure RUN_DIR|events.json -o OUT.png
    adverbs graph GRAPH.toml [--describe [--json] | --plan FROM TO | --play SCRIPT -o OUT.bvh|OUT.glb [--seconds S]
                  [--fps F] [--seed N] [--adverb NAME=VALUE ...] [--floor ...] [--start VERB]]
    adverbs run [GRAPH.toml ...] --script SCRIPT.toml --out DIR [--realtime] [--fps N] [--seed S] [--seconds S]
                [--format bvh,glb] [--portable]
    adverbs render MOTION.bvh ... -o OUT.gif|OUT.mp4|OUT.png [--camera C] [--fps F] [--size WxH] [--fixed] [--floor ...]
    adverbs demo [--out DIR]
    adverbs view [GRAPH.toml | VERB] [--creatures N] [--host H] [--port P] [--fps F] [--seed S] [--no-ik]
    adverbs dataset SPEC.toml --out DIR [--workers N | --scheduler ADDRESS] [--dashboard [ADDRESS]] [--check]

Errors in the input print one line naming the file and line and exit with status 1.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from ..errors import AdverbsError, AdverbsWarning
from ..graph.performance import repeat
from ..io import motion_format, read_motion, write_motion
from ..kinematics.floor import parse_floor
from ..limits import check_environment
from ..motion.clip import Clip
from ..motion.contacts import find_contacts
from ..verb.fit import verb_from
from ..feet.measures import foot_drift, measure_feet
from ..feet.offline import plant_feet
from ..verb.store import load_verb, save_verb
from ..verb.synthesis import plan
from ..verb.tables import Verb
from . import scene
from .evaluate import DATA, METHODS, SPLITS, evaluate, held_out, predict
from .terminal import progress_bar


def info(clip: Clip, path: str | Path) -> dict:
    """What ``adverbs info`` reports, as plain data."""
    skel = clip.skeleton
    feet: dict = {}
    try:
        feet = find_contacts(clip).to_dict()
        for side in feet.values():
            side["ankle"] = skel.names[side["ankle"]]
            side["toe"] = None if side["toe"] is None else skel.names[side["toe"]]
    except AdverbsError:
        feet = {}
    return {
        "file": str(path),
        "frames": clip.num_frames,
        "fps": clip.fps,
        "duration": clip.duration,
        "units": skel.units,
        "unit_scale": skel.unit_scale,
        "channels": int(sum(len(c) for c in skel.channels)),
        "joints": [
            {
                "name": skel.names[j],
                "parent": None if skel.parents[j] < 0 else skel.names[skel.parents[j]],
                "channels": list(skel.channels[j]),
                "side": skel.side(j),
            }
            for j in range(skel.num_joints)
        ],
        "body_root": skel.names[skel.body_root()],
        "feet": feet,
    }


def _print_info(report: dict) -> None:
    print(f"{report['file']}")
    print(
        f"  {report['frames']} frames at {report['fps']:g} fps = {report['duration']:.3f} s; "
        f"{len(report['joints'])} joints, {report['channels']} channels; units {report['units']}"
    )
    print(f"  body root: {report['body_root']}")
    for j in report["joints"]:
        side = f" [{j['side']}]" if j["side"] else ""
        print(f"    {j['name']:<16} parent {j['parent']!s:<16} {' '.join(j['channels'])}{side}")
    if not report["feet"]:
        print("  feet: none found from joint names")
    for side, foot in report["feet"].items():
        spans = ", ".join(f"{a}-{b - 1}" for a, b in foot["contacts"])
        print(f"  {side} foot ({foot['ankle']}, toe {foot['toe']}): contacts at frames {spans or 'none'}")
        print(f"    heel strikes at {', '.join(f'{t:.3f}' for t in foot['heel_strikes_s']) or 'none'} s")


def _frame_range(text: str) -> tuple[int | None, int | None]:
    a, sep, b = text.partition(":")
    if not sep:
        raise argparse.ArgumentTypeError(f"--frames takes A:B (Python slice of frames), got {text!r}")
    try:
        return (int(a) if a.strip() else None, int(b) if b.strip() else None)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--frames takes whole frame numbers A:B, got {text!r}") from None


def _number(text: str, zero: bool) -> float:
    """A finite number from an argument, above 0 (or at least 0 with ``zero``)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (np.isfinite(value) and (value >= 0 if zero else value > 0)):
        raise argparse.ArgumentTypeError(f"expected a {'number ≥ 0' if zero else 'positive number'}, got {text!r}")
    return value


def _workers(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
    if not 0 <= n <= 4096:
        raise argparse.ArgumentTypeError(f"must be from 0 to 4096, got {n}")
    return n


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number ≥ 0, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a whole number ≥ 0, got {text!r}")
    return value


def _positive(text: str) -> float:
    return _number(text, zero=False)


def _non_negative(text: str) -> float:
    return _number(text, zero=True)


PORTABLE_HELP = "a BVH with position channels on the root only, which every reader (three.js, pybvh) reads alike"


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="adverbs", description="Verbs and adverbs: controllable motion from examples."
    )
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("info", help="describe a BVH file: joints, channels, frames, units, feet and contacts")
    p.add_argument("file", type=Path)
    p.add_argument("--json", action="store_true", help="print JSON instead of text")

    p = sub.add_parser(
        "convert", help="read a BVH or glTF (.glb) file, transform it, write BVH or glTF (by the extensions)",
        description=(
            "Read IN (.bvh, or a .glb with one skin and one animation), optionally cut, mirror or resample it, and "
            "write OUT: .bvh in the input's channels, or with --portable the BVH every reader reads alike (position "
            "channels on the root only; three.js, pybvh, Blender); .glb for engines and the web (Unity, Unreal, "
            "Godot, Blender, three.js)."
        ),
    )  # fmt: skip
    p.add_argument("input", type=Path, metavar="IN")
    p.add_argument("output", type=Path, metavar="OUT")
    p.add_argument("--portable", action="store_true", help=PORTABLE_HELP)
    p.add_argument("--frames", type=_frame_range, metavar="A:B", help="keep frames A:B (before other changes)")
    p.add_argument("--mirror", action="store_true", help="swap left and right")
    p.add_argument("--fps", type=_positive, help="resample to this frame rate")
    p = sub.add_parser("build", help="build a verb from a spec (TOML) and save it")
    p.add_argument("spec", type=Path)
    p.add_argument("-o", "--output", type=Path, required=True, help="where to write the verb")

    p = sub.add_parser("describe", help="adverbs, examples, keytimes and sizes of a built verb")
    p.add_argument("verb", type=Path)
    p.add_argument("--json", action="store_true", help="print JSON instead of text")

    p = sub.add_parser("synth", help="motion at an adverb point, written as BVH or glTF (.glb)")
    p.add_argument("verb", type=Path)
    p.add_argument(
        "--adverb",
        action="append",
        default=[],
        type=_assignment,
        metavar="NAME=VALUE",
        help="an adverb value (repeat; adverbs not given take the examples' mean)",
    )
    length = p.add_mutually_exclusive_group()
    length.add_argument("--cycles", type=_positive, help="how many cycles (default 1)")
    length.add_argument("--duration", type=_positive, help="seconds of motion")
    p.add_argument("--fps", type=_positive, help="frame rate (default: the examples')")
    p.add_argument("--no-ik", action="store_true", help="leave the feet where the verb puts them (to compare)")
    p.add_argument(
        "--method", default="ours", choices=METHODS,
        help="how the examples are interpolated: ours (the verb, default) or another method to compare",
    )  # fmt: skip
    p.add_argument(
        "--clamp", nargs="?", const=0.0, default=None, type=_non_negative, metavar="MARGIN",
        help="keep every adverb inside the examples' range (widened by MARGIN ranges, default 0)",
    )  # fmt: skip
    p.add_argument(
        "--floor", default=None, metavar="slope:DEGREES|flat:LEVEL|FILE",
        help="the ground: flat (default, the verb's floor), slope:DEGREES rising along +Z, flat:LEVEL a level floor at "
        "that height, or a height map .npz",
    )  # fmt: skip
    p.add_argument("-o", "--output", type=Path, required=True, metavar="OUT.bvh|OUT.glb")
    p.add_argument("--portable", action="store_true", help=PORTABLE_HELP)

    p = sub.add_parser("evaluate", help="leave-one-out against other interpolators, and adverb obedience")
    p.add_argument("verb", type=Path)
    p.add_argument("--png", type=Path, help="also plot to this PNG file")
    p.add_argument("--json", action="store_true", help="print JSON instead of tables")

    p = sub.add_parser(
        "figure", help="figures of a verb's adverb space: a grid of poses, or one example's weight as a heat map",
        description=(
            "Draw a verb (a built .verb file, or a spec .toml, built first) across two of its adverbs: --kind poses "
            "(default) a grid of poses with the examples over it in another colour, like the paper's Figures 3-4; "
            "--kind space the examples as points with one example's cardinal weight as a heat map; --kind feet the toes "
            "with and without planted feet (from above, and their heights over time). Given a run instead (the folder "
            "of adverbs run --out DIR, or its events.json): each creature's root path coloured by verb, and a timeline."
        ),
    )  # fmt: skip
    p.add_argument("verb", type=Path, metavar="VERB|RUN")
    p.add_argument(
        "--axes", nargs=2, metavar=("A", "B"), help="the two adverbs across the figure (poses, space; default: a verb's two)"
    )
    p.add_argument("--kind", choices=("poses", "space", "feet", "run"), help="default: run for a run, else poses")
    p.add_argument("--size", type=int, default=5, help="poses along each axis (default 5)")
    p.add_argument("--example", type=int, default=0, help="with --kind space: whose weight (default the first example)")
    p.add_argument("-o", "--output", type=Path, required=True, metavar="OUT.png")

    p = sub.add_parser("heldout", help="predict held-out takes of the Bandai dataset-2 classes from the others")
    p.add_argument("--data", type=Path, default=DATA, help="folder of the Bandai BVH files (default: the shipped ones)")
    p.add_argument(
        "--split", choices=SPLITS, default="odd-even",
        help="odd takes build and even takes are predicted (default), the other way round, or each take from all the others",
    )  # fmt: skip

    p = sub.add_parser(
        "graph", help="a verb graph (spec TOML): describe it, plan a path through it, or play a script of commands",
        description=(
            "Load a verb graph (a graph spec TOML; its verbs are built as it loads, progress on stderr) and "
            "describe it (the default), plan the fewest transitions between two verbs, or play one creature "
            "through it following a script of timed commands and write the planted motion as BVH."
        ),
        epilog=(
            "SCRIPT is a comma-separated list of cues, each TIME:VERB (perform VERB from TIME seconds on) or "
            "TIME:NAME=VALUE (set adverb NAME from TIME on), e.g. --play \"1:run,4.5:turn=30,6:walk\". Before a "
            "command, and after it is done, the creature takes default transitions drawn by likelihood (--seed). "
            "Commands the graph refuses (an unknown or unreachable verb, an unknown adverb) are reported as "
            "warnings; the run goes on. Examples: adverbs graph graphs/cmu.toml; adverbs graph graphs/cmu.toml "
            "--plan walk run; adverbs graph graphs/cmu.toml --play \"0.5:run,4:walk\" --seconds 6 -o out/walk_run.bvh"
        ),
    )  # fmt: skip
    p.add_argument("graph", type=Path, metavar="GRAPH.toml", help="a graph spec (graphs/ has the shipped ones)")
    action = p.add_mutually_exclusive_group()
    action.add_argument(
        "--describe", action="store_true",
        help="list the verbs, shared adverbs, transitions and what each verb reaches (default)",
    )  # fmt: skip
    action.add_argument("--plan", nargs=2, metavar=("FROM", "TO"), help="the fewest transitions from FROM to TO")
    action.add_argument("--play", type=_script, metavar="SCRIPT", help="play a script of cues (see below); needs -o")
    p.add_argument("--json", action="store_true", help="with --describe: print JSON instead of text")
    p.add_argument("-o", "--output", type=Path, help="with --play: the .bvh or .glb file to write (the planted motion)")
    p.add_argument("--portable", action="store_true", help="with --play and a .bvh: " + PORTABLE_HELP)
    p.add_argument("--seconds", type=_positive, help=f"with --play: how long to play (default {GRAPH_SECONDS:g})")
    p.add_argument("--fps", type=_positive, help=f"with --play: frame rate (default {GRAPH_FPS:g})")
    p.add_argument("--seed", type=_seed, help="with --play: seeds the transitions drawn by likelihood (default 0)")
    p.add_argument(
        "--adverb", action="append", type=_assignment, metavar="NAME=VALUE",
        help="with --play: where a graph adverb starts (repeat; default: the graph's defaults)",
    )  # fmt: skip
    p.add_argument(
        "--floor", metavar="slope:DEGREES|flat:LEVEL|FILE",
        help="with --play: the ground the feet are planted on (default flat at height 0)",
    )  # fmt: skip
    p.add_argument("--start", metavar="VERB", help="with --play: the verb to start in (default: the graph's)")
    p.set_defaults(graph_parser=p)
    scene.add_parsers(sub, _positive, _seed)

    p = sub.add_parser(
        "dataset", help="a motion dataset from a spec: verbs over their adverb space, graphs under random scripts, on Dask",
        description=(
            "Make the clips a dataset spec (TOML; datasets/ has examples) asks for: each verb at adverb points drawn over "
            "its examples' range (grid, uniform, Sobol, Latin hypercube or listed), each graph under random scripts; "
            "feet planted; written in shards (NumPy arrays, BVH, glTF) with a Parquet manifest, as shards finish. A run "
            "that stopped is resumed by the same command: finished shards are skipped. By default on a local Dask "
            "cluster of one worker process per core (127.0.0.1, no dashboard); --workers 0 in this process alone."
        ),
    )  # fmt: skip
    p.add_argument("spec", type=Path, metavar="SPEC.toml")
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="the dataset's folder (new, empty, or this dataset's to resume)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=_workers, help="worker processes of the local cluster (default: one per core; 0: no cluster)")
    where.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask cluster's scheduler (tcp://HOST:8786)")
    p.add_argument("--dashboard", nargs="?", const=True, default=False, metavar="ADDRESS", help="serve the local cluster's dashboard (default :8787)")
    p.add_argument("--check", action="store_true", help="check the spec, build its verbs and plan the clips; make nothing")
    return parser


GRAPH_SECONDS = 10.0  # adverbs graph --play: default length
GRAPH_FPS = 30.0
_PLAY_ONLY = ("output", "seconds", "fps", "seed", "adverb", "floor", "start")


def _script(text: str) -> list:
    """The cues of ``--play``: comma-separated ``TIME:VERB`` or ``TIME:NAME=VALUE``, checked before any work."""
    from ..graph import Cue

    cues = []
    form = "expected TIME:VERB or TIME:NAME=VALUE (e.g. 1:run or 4.5:turn=30)"
    for raw in text.split(","):
        cue = raw.strip()
        if not cue:
            raise argparse.ArgumentTypeError(f"an empty cue in {text!r} (two commas, or one at an end): {form}")
        when, sep, what = (x.strip() for x in cue.partition(":"))
        if not sep or not when or not what:
            raise argparse.ArgumentTypeError(f"cue {cue!r}: {form}")
        try:
            t = float(when)
        except ValueError:
            raise argparse.ArgumentTypeError(f"cue {cue!r}: the time {when!r} is not a number of seconds") from None
        if not (np.isfinite(t) and t >= 0):
            raise argparse.ArgumentTypeError(f"cue {cue!r}: the time must be a number of seconds ≥ 0, got {when!r}")
        name, sep, value = (x.strip() for x in what.partition("="))
        if not name or any(c.isspace() or c in ":=" for c in name):
            raise argparse.ArgumentTypeError(f"cue {cue!r}: {form}")
        if not sep:
            cues.append(Cue(t, verb=name))
            continue
        try:
            name, number = _assignment(f"{name}={value}")
        except argparse.ArgumentTypeError as e:
            raise argparse.ArgumentTypeError(f"cue {cue!r}: adverb {e}") from None
        cues.append(Cue(t, adverbs={name: number}))
    return cues


def _check_graph_usage(args: argparse.Namespace) -> None:
    """Options of ``adverbs graph`` that belong to another action are usage errors (status 2)."""
    sub = args.graph_parser  # its own usage line in the message
    if args.json and (args.plan or args.play is not None):
        sub.error("--json goes with --describe")
    if args.play is None:
        given = [f"--{k}" if k != "output" else "-o" for k in _PLAY_ONLY if getattr(args, k) is not None]
        if given:
            sub.error(f"{', '.join(given)} {'goes' if len(given) == 1 else 'go'} with --play")
    elif args.output is None:
        sub.error("--play needs -o OUT.bvh")


def _assignment(text: str) -> tuple[str, float]:
    name, sep, value = text.partition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, got {text!r}")
    try:
        number = float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{name}: {value!r} is not a number") from None
    if not np.isfinite(number):
        raise argparse.ArgumentTypeError(f"{name}: {value!r} is not a finite number")
    return name, number


def describe(verb: Verb) -> dict:
    """What ``adverbs describe`` reports, as plain data."""
    lo, hi = verb.points.min(axis=0), verb.points.max(axis=0)
    return {
        "name": verb.name,
        "cyclic": verb.cyclic,
        "num_cp": verb.num_cp,
        "dofs": verb.encoding.num_dofs,
        "encoding": verb.encoding.kind,
        "num_keytimes": verb.num_keytimes,
        "keytime_names": list(verb.keytime_names),
        "constraints": [c.to_dict() for c in verb.constraints],
        "holds": [h.to_dict() for h in verb.holds],
        "floor": verb.floor,
        "fps": verb.fps,
        "smoothing": verb.smoothing,
        "shrinkage": verb.shrinkage,
        "timing": verb.timing,
        "goal_chain": list(verb.goal_chain),
        "skeleton": {"joints": list(verb.skeleton.names), "units": verb.skeleton.units},
        "adverbs": [
            {"name": a.name, "unit": a.unit, "measure": a.measure, "min": float(lo[i]), "max": float(hi[i])}
            for i, a in enumerate(verb.adverbs)
        ],
        "examples": [
            {
                "name": x.name,
                "adverbs": {a.name: float(verb.points[i, k]) for k, a in enumerate(verb.adverbs)},
                "keytimes": [float(v) for v in verb.keytimes_table[i]],
                "source": x.source,
                "part": x.part,
                "fit_error_mm": round(1000.0 * x.fit_error, 3),
                "fine_error_mm": round(1000.0 * x.fine_error, 3),
            }
            for i, x in enumerate(verb.examples)
        ],
    }


def _print_describe(d: dict) -> None:
    kind = "cyclic" if d["cyclic"] else "one-shot"
    print(f"verb {d['name']}: {kind}, {len(d['examples'])} examples, {len(d['adverbs'])} adverbs")
    print(f"  {d['dofs']} DOFs ({d['encoding']}), NumCP {d['num_cp']}, {d['fps']:g} fps")
    print(f"  keytimes: {', '.join(d['keytime_names'])}")
    exact = d["smoothing"] == 0 and d["shrinkage"] == 0
    how = "exact" if exact else f"smoothing {d['smoothing']:g}, shrinkage {d['shrinkage']:g}"
    timing = "extrapolated" if d["timing"] == "extrapolate" else "clamped to the examples' own"
    print(f"  interpolation: {how}; past the examples, keytime intervals {timing}")
    if d["goal_chain"]:
        print(f"  goal chain: {', '.join(d['goal_chain'])}")
    names = d["keytime_names"]
    for c, h in zip(d["constraints"], d["holds"]):
        print(
            f"  constraint: {c['effector']} held from '{names[c['open']]}' ({c['open']}) to '{names[c['close']]}' ({c['close']})"
        )
        if h["height"] is not None:
            print(
                f"    in generic time (the examples' means): lands {h['open']:.3f}, flat {h['toe_down']:.3f}, heel "
                f"lifts {h['heel_off']:.3f}, toe-off {h['close'] % 1 if d['cyclic'] else h['close']:.3f}; "
                f"toe joint {1000 * h['height']:.0f} mm above the floor while down"
            )
    print("  adverbs:")
    for a in d["adverbs"]:
        how = f"measured: {a['measure']['kind']}" if a["measure"] else "given by hand"
        print(f"    {a['name']:<10} [{a['unit']}] {a['min']:.4g} .. {a['max']:.4g}  ({how})")
    print("  examples:")
    for x in d["examples"]:
        values = ", ".join(f"{k}={v:.4g}" for k, v in x["adverbs"].items())
        keys = ", ".join(f"{k:.3f}" for k in x["keytimes"])
        print(f"    {x['name']:<42} {values}")
        print(f"      {x['source']} ({x['part']}); keytimes {keys} s; fit error {x['fit_error_mm']:.1f} mm "
              f"(pose between frames {x['fine_error_mm']:.1f} mm)")


def _print_graph(d: dict) -> None:
    """``adverbs graph --describe``: the verbs, shared adverbs, transitions and reachability of ``Graph.describe()``."""
    added = sum(t["added"] for t in d["transitions"])
    print(
        f"graph {d['name']} ({d['source']}): {len(d['verbs'])} verbs, {len(d['transitions'])} transitions "
        f"({added} added by the graph); creatures start in {d['start']}"
    )
    print("  adverbs (shared by name: every verb that takes one reads the same value), where they start:")
    width = max((len(a) for a in d["adverbs"]), default=0)
    values = {a: f"{x:.4g}" for a, x in d["adverbs"].items()}
    wide = max((len(x) for x in values.values()), default=0)
    for a, x in values.items():
        takers = [v["name"] for v in d["verbs"] if a in v["adverbs"]]
        print(f"    {a:<{width}} = {x:<{wide}}  taken by {', '.join(takers)}")
    if not d["adverbs"]:
        print("    none")
    print("  verbs:")
    width = max(len(v["name"]) for v in d["verbs"])
    for v in d["verbs"]:
        kind = "cyclic  " if v["cyclic"] else "one-shot"
        takes = ", ".join(v["adverbs"]) or "no adverbs"
        ignores = f"; ignores {', '.join(v['ignores'])}" if v["ignores"] else ""
        clamped = "; clamped to its examples' ranges" if v["clamped"] else ""
        start = "  (start)" if v["name"] == d["start"] else ""
        print(f"    {v['name']:<{width}}  {kind} {v['examples']:>2} examples; takes {takes}{ignores}{clamped}{start}")
    print("  transitions (regions in generic time; chance: how often it is drawn when nothing is asked):")
    out_of: dict[str, float] = {}
    for t in d["transitions"]:
        out_of[t["from"]] = out_of.get(t["from"], 0.0) + t["likelihood"]
    arrows = [f"{t['from']} → {t['to']}" for t in d["transitions"]]
    width = max((len(a) for a in arrows), default=0)
    for arrow, t in zip(arrows, d["transitions"]):
        (a0, a1), (b0, b1) = t["from_region"], t["to_region"]
        print(
            f"    {arrow:<{width}}  from_region [{a0:.2f}, {a1:.2f}], to_region [{b0:.2f}, {b1:.2f}], "
            f"likelihood {t['likelihood']:g} (chance {t['likelihood'] / out_of[t['from']]:.0%}), {t['blend']}"
            f"{', interruptible' if t['interruptible'] else ', not interruptible'}"
            f"{', arms ' + t['arms'] if t.get('arms') else ''}"
            f"{', added: the cycle loops into itself' if t['added'] else ''}"
        )
    print("  reachability:")
    names = [v["name"] for v in d["verbs"]]
    width = max(len(n) for n in names)
    for v in d["verbs"]:
        cannot = [n for n in names if n not in v["reaches"]]
        also = f" (not {', '.join(cannot)})" if cannot else ""
        print(f"    from {v['name']:<{width}} reaches {', '.join(v['reaches'])}{also}")
    start = next(v for v in d["verbs"] if v["name"] == d["start"])
    lost = [n for n in names if n not in start["reaches"]]
    if lost:
        them = "it" if len(lost) == 1 else "them"
        print(
            f"  warning: {', '.join(lost)} cannot be reached from the start verb {d['start']}: a creature starting "
            f"there never plays {them} (commands to {them} are refused)"
        )
    else:
        print(f"  every verb can be reached from the start verb {d['start']}")


def _play_line(graph, perf, floor, output: Path) -> str:
    """The one line ``adverbs graph --play`` prints: what was written, what played, latencies and the feet."""
    clip = perf.planted
    played = [graph.verb_names[v] for v in perf.verb]
    order = [n for i, n in enumerate(played) if i == 0 or played[i - 1] != n]
    waits = [f"{name} {seconds:.2f} s" for _, name, seconds in perf.state.latencies]
    if perf.state.goal[0] >= 0:
        waits.append(f"{graph.verb_names[perf.state.goal[0]]} not reached by the end")
    latency = f"command latencies: {', '.join(waits)}" if waits else "no verb commands"
    holding = next((v for v in graph.verbs if v.holds), None)
    if holding is None:
        feet = "feet not planted (no verb of the graph holds a foot)"
    else:
        metrics = measure_feet(holding, clip, perf.report, floor, perf.free)
        feet = f"feet planted: {metrics.line()}" if len(metrics.toe_drift) else "feet planted: no contact phase"
    return (
        f"wrote {output}: {clip.num_frames} frames at {clip.fps:g} fps = {clip.num_frames / clip.fps:.2f} s; "
        f"played {' → '.join(order)}; {latency}; {feet}"
    )


def _graph(args: argparse.Namespace) -> None:
    from ..graph import load_graph, perform
    from ..graph.performance import MAX_SECONDS
    from ..kinematics.floor import FlatFloor

    if args.play is not None:  # everything about the run that can be checked before the graph is built
        seconds = GRAPH_SECONDS if args.seconds is None else args.seconds
        fps = GRAPH_FPS if args.fps is None else args.fps
        if seconds > MAX_SECONDS:
            raise AdverbsError(f"--seconds {seconds:g}: at most {MAX_SECONDS:g}")
        if not 1 <= fps <= 1000:
            raise AdverbsError(f"--fps {fps:g}: must be from 1 to 1000")
        floor = parse_floor(args.floor) if args.floor is not None else FlatFloor(0.0)
        last = (round(seconds * fps) - 1) / fps  # the time of the last frame: a cue after it never plays
        for c in args.play:
            if c.time > last + 1e-9:
                what = c.verb if c.verb is not None else ", ".join(f"{k}={v:g}" for k, v in c.adverbs.items())
                warn = f"adverbs: warning: cue {c.time:g}:{what} comes after the last frame ({last:.3f} s)"
                print(warn, file=sys.stderr)
    print(f"loading graph {args.graph}", file=sys.stderr)
    start = time.perf_counter()
    graph = load_graph(args.graph, progress=True)
    print(f"  loaded graph {graph.name!r} in {time.perf_counter() - start:.1f} s", file=sys.stderr)
    if args.plan:
        a, b = args.plan
        path = graph.path(a, b)
        for k in path:
            t = graph.transitions[k]
            (a0, a1), (b0, b1) = t.source_region, t.target_region
            print(
                f"{graph.verb_names[t.source]} → {graph.verb_names[t.target]}  (from_region [{a0:.2f}, {a1:.2f}] "
                f"to_region [{b0:.2f}, {b1:.2f}], {t.blend})"
            )
        n = len(path)
        print(f"{n} transition{'' if n == 1 else 's'} from {a} to {b}" + (" (already there)" if not n else ""))
    elif args.play is not None:
        print(f"  playing {seconds:g} s at {fps:g} fps", file=sys.stderr)
        perf = perform(
            graph, args.play, seconds=seconds, fps=fps, seed=args.seed or 0, floor=floor, start=args.start,
            adverbs=dict(args.adverb or []),
        )  # fmt: skip
        for when, reason in perf.refused:
            print(f"adverbs: warning: command at {when:g} s refused: {reason}", file=sys.stderr)
        for warning in perf.report.warnings:
            print(f"adverbs: warning: {warning}", file=sys.stderr)
        write_motion(perf.planted, args.output, portable=args.portable)
        print(_play_line(graph, perf, floor, args.output))
        if perf.cues:
            print("cues:")
            for line in perf.cue_lines():
                print("  " + line)
    else:
        d = graph.describe()
        if args.json:
            print(json.dumps(d, indent=2))
        else:
            _print_graph(d)


def _dataset(args: argparse.Namespace) -> None:
    from ..dataset import dataset, prepare

    if args.check:
        prepared = prepare(args.spec, lambda s: print(f"  {s}", file=sys.stderr))
        ok = f"{args.spec}: {len(prepared.tasks):,} clips in {len(prepared.shards)} shards"
        print(f"{ok} of {prepared.spec.shard_size}, from {len(prepared.sources)} sources; formats {', '.join(prepared.spec.formats)}")
        return
    print(f"reading {args.spec}", file=sys.stderr)
    try:
        summary = dataset(args.spec, args.out, workers=args.workers, scheduler=args.scheduler, dashboard=args.dashboard, progress=True)
    except KeyboardInterrupt:
        print(f"adverbs: the finished shards are kept in {args.out}; the same command makes the rest", file=sys.stderr)
        raise
    print(summary.line())
    for shard, why in summary.shard_errors:
        print(f"adverbs: shard {shard} failed: {why}", file=sys.stderr)
    if summary.shard_errors:
        raise AdverbsError(f"{args.out}: {len(summary.shard_errors)} shards not made; run the same command again to make them")


def _run(args: argparse.Namespace) -> None:
    output = getattr(args, "output", None)
    if args.command in ("convert", "synth", "graph") and output is not None:
        motion_format(output)  # an output this cannot write is refused before any work
        if args.portable and motion_format(output) != ".bvh":
            raise AdverbsError(f"--portable is a kind of BVH, but {output} is not a .bvh file")
    if args.command in ("run", "render", "demo", "view"):
        scene.main(args)
    elif args.command == "info":
        clip = read_motion(args.file)
        report = info(clip, args.file)
        if args.json:
            print(json.dumps(report, indent=2))
        else:
            _print_info(report)
    elif args.command == "convert":
        clip = read_motion(args.input)
        if args.frames is not None:
            clip = clip.frames(*args.frames)
        if args.mirror:
            clip = clip.mirror()
        if args.fps is not None:
            clip = clip.resample(args.fps)
        write_motion(clip, args.output, portable=args.portable)
        print(f"wrote {args.output}: {clip.num_frames} frames at {clip.fps:g} fps")
    elif args.command == "build":
        from ..verb.fit import build_from_spec

        start = time.perf_counter()
        verb = build_from_spec(args.spec)
        seconds = time.perf_counter() - start
        save_verb(verb, args.output)
        worst = max(x.fit_error for x in verb.examples)
        print(
            f"built {verb.name}: {len(verb.examples)} examples, {len(verb.adverbs)} adverbs, "
            f"{verb.encoding.num_dofs} DOFs x {verb.num_cp} control points in {seconds:.2f} s; "
            f"largest B-spline fit error {1000 * worst:.1f} mm; wrote {args.output}"
        )
    elif args.command == "describe":
        d = describe(load_verb(args.verb))
        if args.json:
            print(json.dumps(d, indent=2))
        else:
            _print_describe(d)
    elif args.command == "synth":
        verb = load_verb(args.verb)
        p = verb.point(dict(args.adverb))
        if args.clamp is not None:
            kept = verb.clamp(p, args.clamp)
            for name, a, b in zip(verb.adverb_names, p, kept):
                if a != b:
                    print(f"adverbs: {name}={a:g} clamped to {b:g} (--clamp {args.clamp:g})", file=sys.stderr)
            p = kept
        floor = parse_floor(args.floor) if args.floor is not None else None
        if floor is not None and (args.no_ik or not verb.constraints):
            why = "--no-ik leaves the feet where the verb puts them" if args.no_ik else "the verb has no constraints"
            raise AdverbsError(f"--floor places the feet on the ground, but {why}")
        if args.method == "ours":
            source = verb
        else:
            plan(verb, p, args.duration, args.cycles, args.fps)  # warned and refused as ours would be, by the examples
            predicted = predict(args.method, verb, p)
            if predicted is None:
                raise AdverbsError(f"--method {args.method} cannot predict from the {len(verb.examples)} examples of {verb.name!r}")
            source = verb.playing(*predicted, p, name=f"{verb.name} by {args.method}")
        cycle = source.duration(p)
        wanted = args.duration if args.duration is not None else (args.cycles or 1.0) * cycle
        if source.cyclic and wanted > cycle * (1.0 + 1e-9):
            # More than one cycle: each goes on into the next through the verb's loop into itself (§5).
            looped, k = repeat(source, p, duration=args.duration, cycles=args.cycles, fps=args.fps, floor=floor)
            free, clip, report = looped.free, looped.planted, looped.report
        else:
            free, k = source.synthesize(p, duration=args.duration, cycles=args.cycles, fps=args.fps)
            clip, report = free, None
        feet = "feet not planted (--no-ik)"
        if verb.constraints and not args.no_ik:
            raw = foot_drift(source, free, k, source.weights(p))
            if report is None:
                clip, report = plant_feet(source, free, k, floor, p)
            metrics = measure_feet(source, clip, report, floor)
            feet = (
                f"feet planted: {metrics.line()} (toe drift without IK {1000 * np.median(raw):.1f} / "
                f"{1000 * raw.max():.1f} mm)"
                if len(metrics.toe_drift)
                else "no contact phase in this stretch of motion"
            )
            for warning in report.warnings:
                print(f"adverbs: warning: {warning}", file=sys.stderr)
        else:
            clip = free
        if not verb.constraints:
            feet = "the verb has no constraints"
        write_motion(clip, args.output, portable=args.portable)
        values = ", ".join(f"{n}={v:g}" for n, v in zip(verb.adverb_names, p)) or "its one example"
        how = "" if args.method == "ours" else f" by {args.method}"
        print(f"wrote {args.output}: {verb.name}{how} at {values}; {clip.num_frames} frames, cycle {k[-1]:.3f} s; {feet}")
    elif args.command == "graph":
        _graph(args)
    elif args.command == "dataset":
        _dataset(args)
    elif args.command == "figure":
        from .figures import figure, is_run, run_figure

        if is_run(args.verb):
            if args.kind not in (None, "run"):
                raise AdverbsError(f"{args.verb} is a run: it draws as --kind run, not --kind {args.kind}")
            print(f"wrote {run_figure(args.verb, args.output)}")
            return
        axes = tuple(args.axes) if args.axes else None
        print(f"wrote {figure(verb_from(args.verb), axes, args.output, args.kind or 'poses', args.size, args.example)}")
    elif args.command == "heldout":
        update, close = progress_bar("predicting held-out takes")
        try:
            print(held_out(data=args.data, progress=update, split=args.split).table())
        finally:
            close()
    elif args.command == "evaluate":
        update, close = progress_bar("leave-one-out")
        try:
            result = evaluate(load_verb(args.verb), progress=update)
        finally:
            close()
        if args.json:
            print(json.dumps(result.to_dict(), indent=2))
        else:
            print(result.table())
        if args.png is not None:
            args.png.parent.mkdir(parents=True, exist_ok=True)
            result.plot(str(args.png))
            if not args.json:
                print(f"\nplot: {args.png}")


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    print(f"adverbs: warning: {message}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.command == "graph":
        _check_graph_usage(args)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always", AdverbsWarning)
            # NumPy's floating-point notes (overflow, invalid value) are not for the user: what matters is checked
            # and ends in one line naming the file or argument
            warnings.simplefilter("ignore", RuntimeWarning)
            warnings.showwarning = _show_warning
            check_environment()  # a malformed ADVERBS_MAX_* variable: one line, before any work
            _run(args)
    except AdverbsError as e:
        print(f"adverbs: error: {e}", file=sys.stderr)
        return 1
    except BrokenPipeError:  # the reader went away (`adverbs describe VERB | head`): nothing more to say
        sys.stdout = open(os.devnull, "w")  # noqa: SIM115 - keeps the interpreter's final flush quiet
        return 0
    except OSError as e:  # an output that cannot be written: a directory, no permission, a full disk
        print(f"adverbs: error: {e.filename or 'a file'}: {e.strerror or e}", file=sys.stderr)
        return 1
    except MemoryError:
        print("adverbs: error: out of memory: ask for less (fewer frames or creatures), or lower the limits in "
              "ADVERBS_MAX_MEMORY so such work is refused before it starts (see adverbs.limits)", file=sys.stderr)  # fmt: skip
        return 1
    except KeyboardInterrupt:  # Ctrl-C: what could be kept was written and said (adverbs run); no traceback
        print("adverbs: interrupted", file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
