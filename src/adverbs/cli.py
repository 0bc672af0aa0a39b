"""The ``adverbs`` command line: how people and scripts drive the library.

    adverbs info FILE.bvh [--json]
    adverbs convert IN.bvh OUT.bvh [--fps F] [--mirror] [--frames A:B]

Errors in the input print one line naming the file and line and exit with status 1.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from .bvh import read_bvh, write_bvh
from .clip import Clip
from .contacts import find_contacts
from .errors import AdverbsError


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


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (np.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return value


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="adverbs", description="Verbs and adverbs: controllable motion from examples."
    )
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("info", help="describe a BVH file: joints, channels, frames, units, feet and contacts")
    p.add_argument("file", type=Path)
    p.add_argument("--json", action="store_true", help="print JSON instead of text")

    p = sub.add_parser("convert", help="read a BVH file, transform it, write a BVH file")
    p.add_argument("input", type=Path)
    p.add_argument("output", type=Path)
    p.add_argument("--frames", type=_frame_range, metavar="A:B", help="keep frames A:B (before other changes)")
    p.add_argument("--mirror", action="store_true", help="swap left and right")
    p.add_argument("--fps", type=_positive, help="resample to this frame rate")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        if args.command == "info":
            clip = read_bvh(args.file)
            report = info(clip, args.file)
            if args.json:
                print(json.dumps(report, indent=2))
            else:
                _print_info(report)
        elif args.command == "convert":
            clip = read_bvh(args.input)
            if args.frames is not None:
                clip = clip.frames(*args.frames)
            if args.mirror:
                clip = clip.mirror()
            if args.fps is not None:
                clip = clip.resample(args.fps)
            args.output.parent.mkdir(parents=True, exist_ok=True)
            write_bvh(clip, args.output)
            print(f"wrote {args.output}: {clip.num_frames} frames at {clip.fps:g} fps")
    except AdverbsError as e:
        print(f"adverbs: error: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
