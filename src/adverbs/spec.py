"""Verb spec files (TOML): what an animator writes by hand to make a verb.

```toml
name = "walk"
encoding = "logquat"          # or "euler" (the paper's channels)
num_cp = 12                   # B-spline control points per DOF (NumCP)
cyclic = true                 # a cycle (walk) or a one-shot motion (reach)
skeleton = "data/x.bvh"       # optional: every example must be on this skeleton
cut = { foot = "left", steps = 2 }   # default part of each file: one cycle from a left heel strike
fps = 30                      # optional: resample every example to this rate (needed when files differ)

[[adverbs]]
name = "turn"
measure = "turn_rate"         # measured from each example; or a table {kind = "joint_position", ...}

[[adverbs]]
name = "mood"                 # no measure: every example gives it by hand
unit = "sad -1 .. happy +1"

[[examples]]
name = "happy"
file = "../data/bandai/dataset-1_walk_happy_001.bvh"
cut = { foot = "left", strike = 1, steps = 2 }    # or strike = "most_turning"
mirror = false
adverbs = { mood = 1.0 }
refine = false                # true: a local refinement, left out of the linear fit (see rbf)
```

An example's part is ``cut`` (heel strike ``strike`` of ``foot``, ``steps`` steps; its keytimes are
the heel strikes) or ``frames = [A, B]`` (a frame range, end exclusive) with ``keytimes`` given in
seconds from the part's start, or ``keytimes = { peak = "JOINT" }`` (start, the joint's highest
point, end). Paths are relative to the spec file. Every mistake raises :class:`SpecError` naming the
file, the example and the field.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

from .bvh import read_bvh
from .clip import Clip
from .constraints import Constraint
from .contacts import find_contacts, step_events, step_range
from .encoding import KINDS
from .errors import AdverbsError
from .measures import MEASURES, check_measure, default_unit, measure, measure_all
from .verb import Adverb, Example, Verb

_TOP = {
    "name",
    "encoding",
    "num_cp",
    "cyclic",
    "skeleton",
    "cut",
    "adverbs",
    "examples",
    "description",
    "floor",
    "constraints",
    "fps",
}
_ADVERB = {"name", "unit", "measure", "description"}
_EXAMPLE = {"name", "file", "cut", "frames", "keytimes", "mirror", "adverbs", "refine", "description"}
_CUT = {"foot", "strike", "steps", "events"}


class SpecError(AdverbsError):
    """A mistake in a verb spec; ``path``, ``example`` and ``field`` say where."""

    def __init__(self, path: Path, reason: str, example: str | None = None, field: str | None = None):
        self.path, self.example, self.field, self.reason = str(path), example, field, reason
        where = str(path)
        if example is not None:
            where += f": example {example!r}"
        if field is not None:
            where += f", field '{field}'" if example is not None else f": field '{field}'"
        super().__init__(f"{where}: {reason}")


def load_spec(path: str | Path) -> dict[str, Any]:
    """Parse and check a spec's structure (types, names, fields); does not read the BVH files."""
    path = Path(path)
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise SpecError(path, "no such spec file") from None
    except UnicodeDecodeError:
        raise SpecError(path, "not a text file (UTF-8)") from None
    except OSError as e:
        raise SpecError(path, f"cannot read: {e.strerror}") from None
    except tomllib.TOMLDecodeError as e:
        raise SpecError(path, f"not valid TOML: {e}") from None
    _unknown(path, raw, _TOP, None)
    name = str(raw.get("name", path.stem))
    if raw.get("cut") is not None and not isinstance(raw["cut"], dict):
        raise SpecError(path, 'must be a table such as { foot = "left", steps = 2 }', field="cut")
    if raw.get("skeleton") is not None and not isinstance(raw["skeleton"], str):
        raise SpecError(path, "must be a path (a string)", field="skeleton")
    encoding = raw.get("encoding", "logquat")
    if encoding not in KINDS:
        raise SpecError(path, f"unknown encoding {encoding!r}; use one of {', '.join(KINDS)}", field="encoding")
    num_cp = raw.get("num_cp", 12)
    if not isinstance(num_cp, int) or num_cp < 4:
        raise SpecError(path, f"num_cp must be a whole number of at least 4, got {num_cp!r}", field="num_cp")
    cyclic = raw.get("cyclic", True)
    if not isinstance(cyclic, bool):
        raise SpecError(path, f"cyclic must be true or false, got {cyclic!r}", field="cyclic")
    adverbs = raw.get("adverbs")
    if not isinstance(adverbs, list) or not adverbs:
        raise SpecError(path, "a verb needs at least one [[adverbs]] entry", field="adverbs")
    seen: set[str] = set()
    for i, a in enumerate(adverbs):
        if not isinstance(a, dict) or not isinstance(a.get("name"), str):
            raise SpecError(path, f"adverb {i + 1} needs a name", field="adverbs")
        _unknown(path, a, _ADVERB, None, f"adverbs.{a['name']}")
        if a["name"] in seen:
            raise SpecError(path, f"adverb {a['name']!r} is listed twice", field="adverbs")
        seen.add(a["name"])
        m = a.get("measure")
        if isinstance(m, str):
            a["measure"] = {"kind": m}
        elif m is not None and not isinstance(m, dict):
            raise SpecError(path, "measure must be a name or a table", field=f"adverbs.{a['name']}.measure")
        if a.get("measure") is not None and a["measure"].get("kind") not in MEASURES:
            raise SpecError(
                path,
                f"unknown measure {a['measure'].get('kind')!r}; measures are {', '.join(MEASURES)}",
                field=f"adverbs.{a['name']}.measure",
            )
    examples = raw.get("examples")
    if not isinstance(examples, list) or len(examples) < 2:
        raise SpecError(path, "a verb needs at least two [[examples]]", field="examples")
    names: set[str] = set()
    for i, ex in enumerate(examples):
        ex_name = ex.get("name", f"#{i + 1}") if isinstance(ex, dict) else f"#{i + 1}"
        if not isinstance(ex, dict):
            raise SpecError(path, "must be a table", ex_name)
        ex["name"] = str(ex_name)
        if ex["name"] in names:
            raise SpecError(path, "two examples have this name", ex["name"], "name")
        names.add(ex["name"])
        _unknown(path, ex, _EXAMPLE, ex["name"])
        if "file" not in ex:
            raise SpecError(path, "missing", ex["name"], "file")
        if not isinstance(ex["file"], str):
            raise SpecError(path, f"must be a path (a string), got {ex['file']!r}", ex["name"], "file")
        if "cut" in ex and not isinstance(ex["cut"], dict):
            raise SpecError(path, 'must be a table such as { foot = "left", steps = 2 }', ex["name"], "cut")
        if "cut" in ex and "frames" in ex:
            raise SpecError(path, "give either 'cut' or 'frames', not both", ex["name"], "frames")
    floor = raw.get("floor", 0.0)
    if isinstance(floor, bool) or not isinstance(floor, int | float) or not math.isfinite(floor):
        raise SpecError(path, f"must be a finite height in metres, got {floor!r}", field="floor")
    fps = raw.get("fps")
    if fps is not None and (isinstance(fps, bool) or not isinstance(fps, int | float) or not 0 < fps < 10000):
        raise SpecError(path, f"must be a frame rate in frames per second, got {fps!r}", field="fps")
    constraints = raw.get("constraints", "auto")
    if constraints != "auto":
        if not isinstance(constraints, list):
            raise SpecError(path, 'must be "auto" or a list of { effector, open, close }', field="constraints")
        for i, c in enumerate(constraints):
            if not isinstance(c, dict) or set(c) != {"effector", "open", "close"}:
                raise SpecError(path, "each needs exactly effector, open and close", field=f"constraints[{i}]")
    return {
        "path": path,
        "name": name,
        "floor": float(floor),
        "fps": None if fps is None else float(fps),
        "constraints": constraints,
        "encoding": encoding,
        "num_cp": num_cp,
        "cyclic": cyclic,
        "skeleton": raw.get("skeleton"),
        "cut": raw.get("cut"),
        "adverbs": adverbs,
        "examples": examples,
    }


def _unknown(path: Path, table: dict, allowed: set[str], example: str | None, prefix: str = "") -> None:
    extra = sorted(set(table) - allowed)
    if extra:
        field = f"{prefix}.{extra[0]}" if prefix else extra[0]
        raise SpecError(path, f"unknown field; fields here are {', '.join(sorted(allowed))}", example, field)


def examples_from_spec(spec: dict[str, Any]) -> tuple[list[Example], list[Adverb]]:
    """Read, cut, annotate and measure every example of a parsed spec."""
    path: Path = spec["path"]
    base = path.parent
    reference = None
    if spec["skeleton"] is not None:
        try:
            reference = read_bvh(base / spec["skeleton"]).skeleton
        except AdverbsError as e:
            raise SpecError(path, str(e), field="skeleton") from None
    examples: list[Example] = []
    pending = []
    for ex in spec["examples"]:
        name = ex["name"]
        file = base / ex["file"]
        if not file.exists():
            raise SpecError(path, f"no such file: {file}", name, "file")
        try:
            clip = read_bvh(file)
        except AdverbsError as e:
            raise SpecError(path, str(e), name, "file") from None
        if spec["fps"] is not None and clip.fps != spec["fps"]:
            clip = clip.resample(spec["fps"])
        elif pending and clip.fps != pending[0][1].fps:
            raise SpecError(
                path,
                f"{file.name} runs at {clip.fps:g} fps and example {pending[0][0]['name']!r} at "
                f"{pending[0][1].fps:g}: set fps = ... at the top of the spec to resample every example",
                name,
                "file",
            )
        if reference is not None and not clip.skeleton.same_structure(reference):
            raise SpecError(path, f"{file.name} is on a different skeleton from {spec['skeleton']}", name, "file")
        if pending:
            first = pending[0][1]
            if not clip.skeleton.same_structure(first.skeleton):
                raise SpecError(
                    path, f"{file.name} is on a different skeleton from example {pending[0][0]['name']!r}", name, "file"
                )
        mirror = ex.get("mirror", False)
        for flag in ("mirror", "refine"):
            if not isinstance(ex.get(flag, False), bool):
                raise SpecError(path, "must be true or false", name, flag)
        if mirror:
            try:
                clip = clip.mirror()
            except AdverbsError as e:
                raise SpecError(path, str(e), name, "mirror") from None
        part, keytimes, names, desc = _cut(path, ex, clip, spec)
        pending.append((ex, clip, part, keytimes, desc, names))

    num_keytimes = len(pending[0][3])
    first_names = pending[0][5]
    if spec["cyclic"] and first_names[0] != first_names[-1] and not first_names[0].startswith("keytime"):
        raise SpecError(
            path,
            f"a cycle must end on the event it starts with, but its keytimes run from '{first_names[0]}' to "
            f"'{first_names[-1]}': use an even number of steps",
            pending[0][0]["name"],
            "cut.steps",
        )
    for ex, _, _, keytimes, _, names in pending:
        if len(keytimes) != num_keytimes:
            raise SpecError(
                path,
                f"has {len(keytimes)} keytimes, example {pending[0][0]['name']!r} has {num_keytimes}: "
                "every example needs the same structure (same number of steps)",
                ex["name"],
                "keytimes",
            )
        if names != pending[0][5]:
            raise SpecError(
                path,
                f"its keytimes are {', '.join(names)}; example {pending[0][0]['name']!r} has "
                f"{', '.join(pending[0][5])}: every example needs the same events in the same order",
                ex["name"],
                "keytimes",
            )

    adverbs = []
    for a in spec["adverbs"]:
        m = a.get("measure")
        if m is not None:
            try:
                m = check_measure(m, pending[0][1].skeleton.names, num_keytimes, f"{path}: adverb {a['name']!r}")
            except AdverbsError as e:
                raise SpecError(path, str(e).split(": ", 2)[-1], field=f"adverbs.{a['name']}.measure") from None
        unit = a.get("unit", default_unit(m["kind"]) if m else "")
        adverbs.append(Adverb(a["name"], str(unit), m))

    for ex, _, part, keytimes, desc, names in pending:
        given = ex.get("adverbs", {})
        if not isinstance(given, dict):
            raise SpecError(path, "must be a table of adverb values", ex["name"], "adverbs")
        unknown = sorted(set(given) - {a.name for a in adverbs})
        if unknown:
            raise SpecError(path, "the verb has no such adverb", ex["name"], f"adverbs.{unknown[0]}")
        point = []
        measured = iter(measure_all(part, keytimes, [a.measure for a in adverbs if a.measure is not None]))
        for a in adverbs:
            field = f"adverbs.{a.name}"
            if a.measure is not None:
                if a.name in given:
                    raise SpecError(
                        path, "this adverb is measured from the motion; do not also give it", ex["name"], field
                    )
                point.append(float(next(measured)))
                continue
            if a.name not in given:
                raise SpecError(
                    path, "missing: this adverb has no measure, so every example must give it", ex["name"], field
                )
            value = given[a.name]
            if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
                raise SpecError(path, f"must be a finite number, got {value!r}", ex["name"], field)
            point.append(float(value))
        for other in examples:
            if np.allclose(other.point, point, rtol=1e-12, atol=1e-12):
                raise SpecError(
                    path,
                    f"examples {other.name!r} and {ex['name']!r} are at the same adverb point {point}; "
                    "examples must be at distinct points",
                    ex["name"],
                    "adverbs",
                )
        examples.append(
            Example(
                ex["name"], part, keytimes, np.array(point), ex["file"], desc, ex.get("refine", False), tuple(names)
            )
        )
    return examples, adverbs


def _cut(path: Path, ex: dict, clip: Clip, spec: dict) -> tuple[Clip, np.ndarray, list[str], str]:
    """The example's part of the clip, its keytimes (seconds), their names, and a description."""
    name = ex["name"]
    if "frames" in ex:
        frames = ex["frames"]
        if not (isinstance(frames, list) and len(frames) == 2 and all(isinstance(f, int) for f in frames)):
            raise SpecError(path, f"must be [A, B] whole frame numbers, got {frames!r}", name, "frames")
        try:
            part = clip.frames(*frames)
        except AdverbsError as e:
            raise SpecError(path, str(e), name, "frames") from None
        if part.num_frames < 2:
            raise SpecError(path, f"{frames} is a single frame; an example needs at least two", name, "frames")
        return (part, *_given_keytimes(path, ex, part), f"frames {frames[0]}:{frames[1]}")
    cut = dict(spec["cut"] or {})
    cut.update(ex.get("cut", {}))
    if not cut:
        return (clip, *_given_keytimes(path, ex, clip), "whole file")
    extra = sorted(set(cut) - _CUT)
    if extra:
        raise SpecError(path, f"unknown field; cut takes {', '.join(sorted(_CUT))}", name, f"cut.{extra[0]}")
    foot, steps, strike = cut.get("foot", "left"), cut.get("steps", 2), cut.get("strike", 0)
    events = cut.get("events", "strikes")
    if not isinstance(steps, int) or steps < 1:
        raise SpecError(path, f"must be a whole number of steps ≥ 1, got {steps!r}", name, "cut.steps")
    if events not in ("strikes", "contacts"):
        raise SpecError(path, f'must be "strikes" or "contacts", got {events!r}', name, "cut.events")
    if "keytimes" in ex:
        raise SpecError(path, "a cut at heel strikes takes its keytimes from them; remove 'keytimes'", name, "keytimes")
    try:
        contacts = find_contacts(clip)
        if strike == "most_turning":
            strikes = _most_turning(clip, foot, steps, contacts)
        elif isinstance(strike, int) and strike >= 0:
            strikes = step_range(contacts, foot, strike, steps, clip.name)
        else:
            raise SpecError(
                path, f'must be a heel-strike index ≥ 0 or "most_turning", got {strike!r}', name, "cut.strike"
            )
    except SpecError:
        raise
    except AdverbsError as e:
        raise SpecError(path, str(e), name, "cut") from None
    start, stop = int(strikes[0]), int(strikes[-1])
    frames, names = step_events(contacts, start, stop, toe_offs=events == "contacts")
    k = int(np.flatnonzero(np.array(contacts.strikes(foot)) == start)[0])
    return (
        clip.frames(start, stop + 1),
        (frames - start) / clip.fps,
        names,
        f"{steps} steps from {foot} heel strike {k}",
    )


def _most_turning(clip: Clip, foot: str, steps: int, contacts) -> np.ndarray:
    """The heel strikes of the cut whose heading changes most: where a turn clip actually turns."""
    best = None
    k = 0
    while True:
        try:
            strikes = step_range(contacts, foot, k, steps, clip.name)
        except AdverbsError:
            break
        part = clip.frames(int(strikes[0]), int(strikes[-1]) + 1)
        turn = abs(measure(part, (strikes - strikes[0]) / clip.fps, {"kind": "heading_change"}))
        if best is None or turn > best[0]:
            best = (turn, strikes)
        k += 1
    if best is None:
        step_range(contacts, foot, 0, steps, clip.name)  # raises the informative error
    return best[1]


def _given_keytimes(path: Path, ex: dict, part: Clip) -> tuple[np.ndarray, list[str]]:
    name = ex["name"]
    given = ex.get("keytimes")
    if given is None:
        raise SpecError(path, "missing: a frame range needs keytimes (seconds, or { peak = JOINT })", name, "keytimes")
    if isinstance(given, dict):
        extra = sorted(set(given) - {"peak"})
        if extra or "peak" not in given:
            raise SpecError(path, 'takes { peak = "JOINT" }', name, "keytimes")
        try:
            j = part.skeleton.index(given["peak"])
        except AdverbsError as e:
            raise SpecError(path, str(e), name, "keytimes.peak") from None
        height = part.global_positions()[:, j, 1]
        peak = int(np.argmax(height))
        if peak == 0 or peak == part.num_frames - 1:
            raise SpecError(
                path, f"{given['peak']} is highest at the first or last frame: no peak inside", name, "keytimes.peak"
            )
        return np.array([0.0, peak / part.fps, part.duration]), ["start", f"{given['peak']} peak", "end"]
    if not isinstance(given, list) or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in given):
        raise SpecError(path, f"must be a list of seconds, got {given!r}", name, "keytimes")
    k = np.array(given, dtype=float)
    if len(k) < 2 or not np.all(np.isfinite(k)):
        raise SpecError(path, "needs at least two finite keytimes", name, "keytimes")
    if k[0] != 0 or abs(k[-1] - part.duration) > 0.5 / part.fps:
        raise SpecError(
            path,
            f"must start at 0 and end at the part's duration {part.duration:.4f} s, got {k[0]} .. {k[-1]}",
            name,
            "keytimes",
        )
    k[-1] = part.duration  # within half a frame: the part's end, exactly
    if np.any(np.diff(k) <= 0):
        i = int(np.argmax(np.diff(k) <= 0))
        raise SpecError(
            path,
            f"out of order: keytime {i + 2} ({k[i + 1]} s) is not after keytime {i + 1} ({k[i]} s)",
            name,
            "keytimes",
        )
    return k, [f"keytime {i}" for i in range(len(k))]


def build_from_spec(path: str | Path) -> Verb:
    """Parse a spec, read and cut its examples, and build the verb."""
    spec = load_spec(path)
    examples, adverbs = examples_from_spec(spec)
    constraints = spec["constraints"]
    if constraints != "auto":
        constraints = [Constraint(str(c["effector"]), c["open"], c["close"]) for c in constraints]
    try:
        return Verb.build(
            spec["name"],
            examples,
            adverbs,
            spec["num_cp"],
            spec["encoding"],
            spec["cyclic"],
            constraints,
            spec["floor"],
        )
    except SpecError:
        raise
    except AdverbsError as e:
        text = str(e)
        example = next((ex.name for ex in examples if f"{ex.name!r}" in text), None)
        field = "adverbs" if "adverb point" in text or "non-finite" in text else None
        if text.startswith("constraint on") or "no joint named" in text:
            field = "constraints"
        raise SpecError(spec["path"], text, example, field) from None
