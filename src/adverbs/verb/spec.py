"""Verb spec files (TOML): what an animator writes by hand to make a verb.

```toml
name = "walk"
encoding = "logquat"          # or "euler" (the paper's channels)
num_cp = 12                   # B-spline control points per DOF (NumCP)
cyclic = true                 # a cycle (walk) or a one-shot motion (reach)
in_place = false              # a one-shot that stays where it stands (a stand looping into itself): the
                              # body root's travel and turn taken off every frame of every example; "feet":
                              # its root is where its feet stand, the hips' sway over them kept in the pose
skeleton = "data/x.bvh"       # optional: every example must be on this skeleton
cut = { foot = "left", steps = 2 }   # default part of each file: one cycle from a left heel strike
fps = 30                      # optional: resample every example to this rate (needed when files differ)
keytime_spacing = "examples"  # keytimes in generic time spaced as the examples' are; "even": the paper's
smoothing = 0                 # interpolation: 0 exact (the paper's); a number or "auto" to approximate
shrinkage = 0                 # shrink the linear part's slopes: 0 (default), a number or "auto"
goal = { chain = ["Chest", "UpperArm_R", "LowerArm_R"] }  # optional: IK puts the joint_position adverbs'
                              # joint on the asked goal at their keytime (see adverbs.verb.goal)
timing = "extrapolate"        # keytime intervals past the examples: "extrapolate" (the paper's) or "clamp"
                              # (each within the examples' shortest and longest: further, never faster)

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

Every value is checked for its type before anything uses it: ``true`` is not the number 1, a table is not a
string, NaN and infinity are not numbers. Whole numbers that count frames (``num_cp``, ``cut.strike``,
``cut.steps``, ``frames``, keytime indices) are at most :data:`adverbs.limits.LIMITS` ``.frames``: none can
exceed the frames of an example, and an example has at most that many. A spec file is at most
:data:`MAX_TOML_BYTES` (it is written by hand), and a line's keys have at most :data:`MAX_KEY_DOTS` dots (Python's
TOML reader takes time and memory quadratic in a dotted key's length).

This module reads and checks the TOML (:func:`load_spec`); :mod:`.examples` reads, cuts and measures
the examples it names, and :func:`adverbs.verb.fit.build_from_spec` builds the verb.
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..errors import AdverbsError
from ..interp.rbf import ADVERB_LIMIT
from ..limits import LIMITS
from ..motion.encoding import KINDS
from .measures import MEASURES
from .tables import TIMINGS

_TOP = {
    "name",
    "encoding",
    "num_cp",
    "cyclic",
    "in_place",
    "skeleton",
    "cut",
    "adverbs",
    "examples",
    "description",
    "floor",
    "constraints",
    "fps",
    "keytime_spacing",
    "smoothing",
    "shrinkage",
    "goal",
    "timing",
}
_ADVERB = {"name", "unit", "measure", "description"}
_EXAMPLE = {"name", "file", "cut", "frames", "keytimes", "mirror", "adverbs", "refine", "description"}
CUT_FIELDS = {"foot", "strike", "steps", "events"}
FEET = ("left", "right")
MAX_TOML_BYTES = 1 << 20  # a spec or graph file is written by hand: the largest shipped is 6 KiB
MAX_KEY_DOTS = 16  # dots in the keys of one line (a spec's keys have at most two: adverbs.mood.kind)
# The key-depth scan: where strings and comments start, how each string's body runs (possessive: linear time), and
# the numbers left in the code between them (1.5, 2e-3, 07:32:00.999), whose dots are not keys' dots.
_OPENERS = re.compile(r"\"\"\"|'''|[\"'#]")
_BODIES = {
    '"""': re.compile(r'(?:[^"\\]|\\.|"(?!""))*+', re.S),
    "'''": re.compile(r"(?:[^']|'(?!''))*+"),
    '"': re.compile(r'(?:[^"\\\n]|\\.)*+'),
    "'": re.compile(r"[^'\n]*+"),
}
_NUMBERS = re.compile(r"(?<![\w.])[+-]?[0-9][0-9_]*(?:\.[0-9][0-9_]*)?(?:[eE][+-]?[0-9][0-9_]*)?(?![\w.])")


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


def read_toml(path: Path, kind: str, error: Callable[[Path, str], AdverbsError]) -> dict[str, Any]:
    """The table in TOML file ``path`` (a ``kind``: "spec", "graph"); what goes wrong is ``error(path, reason)``.

    A file over :data:`MAX_TOML_BYTES`, or with a line whose keys have more than :data:`MAX_KEY_DOTS` dots, is
    refused before it is parsed; so is TOML nested too deeply or an integer of thousands of digits."""
    return read_toml_text(path, kind, error)[0]


def read_toml_text(path: Path, kind: str, error: Callable[[Path, str], AdverbsError]) -> tuple[dict[str, Any], str]:
    """:func:`read_toml`'s table and the text it was read from (lines ending in ``\\n``), for messages that name
    a line."""
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_TOML_BYTES + 1)
    except FileNotFoundError:
        raise error(path, f"no such {kind} file") from None
    except OSError as e:
        raise error(path, f"cannot read: {e.strerror or e}") from None
    if len(data) > MAX_TOML_BYTES:
        raise error(path, f"over {MAX_TOML_BYTES >> 10} KiB: a {kind} file is written by hand, and this is far more")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise error(path, "not a text file (UTF-8)") from None
    text = text.replace("\r\n", "\n").replace("\r", "\n")  # as a text-mode read gives it
    line, dots = _most_key_dots(text)
    if dots > MAX_KEY_DOTS:
        raise error(path, f"line {line}: keys with {dots} dots; a {kind}'s keys need at most {MAX_KEY_DOTS}")
    try:
        return tomllib.loads(text), text
    except tomllib.TOMLDecodeError as e:
        raise error(path, f"not valid TOML: {e}") from None
    except RecursionError:
        raise error(path, "not valid TOML: arrays or tables nested too deeply") from None
    except ValueError as e:  # an integer of more digits than Python converts
        raise error(path, f"not valid TOML: {e}") from None


def _most_key_dots(text: str) -> tuple[int, int]:
    """The line (1-based) whose code has the most dots outside strings, comments and numbers, and how many.

    Linear time: strings are skipped as TOML reads them (escapes; a multi-line string may end with one or two
    quotes of its own before its delimiter); the scan stops at a string that never closes, where the TOML reader
    stops too."""
    code = []
    pos = 0
    while True:
        m = _OPENERS.search(text, pos)
        if m is None:
            code.append(text[pos:])
            break
        code.append(text[pos : m.start()])
        opener = m.group()
        if opener == "#":
            end = text.find("\n", m.end())
            pos = len(text) if end < 0 else end
            continue
        end = _BODIES[opener].match(text, m.end()).end()
        if not text.startswith(opener, end):
            break  # never closed: invalid TOML, and the reader reads nothing after it
        end += len(opener)
        if len(opener) == 3:
            for _ in range(2):
                if text.startswith(opener[0], end):
                    end += 1
        code.append(" s " + "\n" * text.count("\n", m.start(), end))
        pos = end
    best = (1, 0)
    for number, line in enumerate("".join(code).split("\n"), start=1):
        if line.count(".") > best[1]:
            dots = _NUMBERS.sub(" ", line).count(".")
            if dots > best[1]:
                best = (number, dots)
    return best


def load_spec(path: str | Path) -> dict[str, Any]:
    """Parse and check a spec's structure (types, names, fields); does not read the BVH files."""
    path = Path(path)
    raw = read_toml(path, "spec", SpecError)
    _unknown(path, raw, _TOP, None)
    name = raw.get("name", path.stem)
    if not isinstance(name, str):
        raise SpecError(path, f"must be a string, got {_show(name)}", field="name")
    _text(path, raw, "description", None)
    if raw.get("cut") is not None:
        _cut(path, raw["cut"], None)
    if raw.get("skeleton") is not None and not isinstance(raw["skeleton"], str):
        raise SpecError(path, "must be a path (a string)", field="skeleton")
    encoding = raw.get("encoding", "logquat")
    if encoding not in KINDS:
        raise SpecError(path, f"unknown encoding {_show(encoding)}; use one of {', '.join(KINDS)}", field="encoding")
    num_cp = raw.get("num_cp", 12)
    if not _whole(num_cp) or not 4 <= num_cp <= LIMITS.frames:
        raise SpecError(
            path,
            f"num_cp must be a whole number from 4 to {LIMITS.frames:,} (it cannot pass an example's frames, and an "
            f"example has at most the frame limit), got {_show(num_cp)}",
            field="num_cp",
        )
    cyclic = raw.get("cyclic", True)
    if not isinstance(cyclic, bool):
        raise SpecError(path, f"cyclic must be true or false, got {_show(cyclic)}", field="cyclic")
    in_place = raw.get("in_place", False)
    if not isinstance(in_place, bool) and in_place != "feet":
        raise SpecError(path, f'in_place must be true, false or "feet", got {_show(in_place)}', field="in_place")
    if in_place and cyclic:
        raise SpecError(
            path, "a cycle's seam is taken off already: in_place is for one-shot verbs (cyclic = false)", field="in_place"
        )
    adverbs = raw.get("adverbs", [])
    if not isinstance(adverbs, list):
        raise SpecError(path, "adverbs must be a list of [[adverbs]] tables", field="adverbs")
    seen: set[str] = set()
    for i, a in enumerate(adverbs):
        if not isinstance(a, dict) or not isinstance(a.get("name"), str):
            raise SpecError(path, f"adverb {i + 1} needs a name", field="adverbs")
        _unknown(path, a, _ADVERB, None, f"adverbs.{a['name']}")
        if a["name"] in seen:
            raise SpecError(path, f"adverb {a['name']!r} is listed twice", field="adverbs")
        seen.add(a["name"])
        for key in ("unit", "description"):
            if key in a and not isinstance(a[key], str):
                raise SpecError(path, f"must be a string, got {_show(a[key])}", field=f"adverbs.{a['name']}.{key}")
        m = a.get("measure")
        if isinstance(m, str):
            a["measure"] = {"kind": m}
        elif m is not None and not isinstance(m, dict):
            raise SpecError(path, "measure must be a name or a table", field=f"adverbs.{a['name']}.measure")
        if a.get("measure") is not None:
            _measure(path, a["measure"], f"adverbs.{a['name']}.measure")
    examples = raw.get("examples")
    if not isinstance(examples, list) or not examples:
        raise SpecError(path, "a verb needs at least one [[examples]] entry", field="examples")
    if len(examples) > 1 and not adverbs:
        raise SpecError(
            path,
            f"{len(examples)} examples need at least one [[adverbs]] entry to tell them apart "
            "(a verb of one example takes none: it plays that example)",
            field="adverbs",
        )
    names: set[str] = set()
    for i, ex in enumerate(examples):
        ex_name = ex.get("name", f"#{i + 1}") if isinstance(ex, dict) else f"#{i + 1}"
        if not isinstance(ex, dict):
            raise SpecError(path, "must be a table", ex_name)
        if not isinstance(ex_name, str):
            raise SpecError(path, f"must be a string, got {_show(ex_name)}", f"#{i + 1}", "name")
        if ex_name in names:
            raise SpecError(path, "two examples have this name", ex_name, "name")
        ex["name"] = ex_name
        names.add(ex_name)
        _unknown(path, ex, _EXAMPLE, ex_name)
        _example(path, ex)
    floor = raw.get("floor", 0.0)
    if not _number(floor):
        raise SpecError(path, f"must be a finite height in metres, got {_show(floor)}", field="floor")
    fps = raw.get("fps")
    if fps is not None and (not _number(fps) or not 0 < fps < 10000):
        raise SpecError(path, f"must be a frame rate in frames per second, got {_show(fps)}", field="fps")
    spacing = raw.get("keytime_spacing", "examples")
    if spacing not in ("examples", "even"):
        raise SpecError(path, f'must be "examples" or "even", got {_show(spacing)}', field="keytime_spacing")
    rules = {}
    for key in ("smoothing", "shrinkage"):
        v = raw.get(key, 0.0)
        if v != "auto" and not (_number(v) and v >= 0):
            raise SpecError(path, f'must be a number ≥ 0 or "auto", got {_show(v)}', field=key)
        rules[key] = v if v == "auto" else float(v)
    goal = raw.get("goal", {})
    if not isinstance(goal, dict):
        raise SpecError(path, f"must be a table {{ chain = [joint names] }}, got {_show(goal)}", field="goal")
    _unknown(path, goal, {"chain"}, None, "goal")
    chain = goal.get("chain", [])
    if not isinstance(chain, list) or not all(isinstance(j, str) for j in chain) or (goal and not chain):
        raise SpecError(path, f"must be a list of one or more joint names, got {_show(chain)}", field="goal.chain")
    timing = raw.get("timing", "extrapolate")
    if timing not in TIMINGS:
        choices = " or ".join(f'"{t}"' for t in TIMINGS)
        raise SpecError(path, f"must be {choices}, got {_show(timing)}", field="timing")
    constraints = raw.get("constraints", "auto")
    if constraints != "auto":
        if not isinstance(constraints, list):
            raise SpecError(path, 'must be "auto" or a list of { effector, open, close }', field="constraints")
        for i, c in enumerate(constraints):
            if not isinstance(c, dict) or set(c) != {"effector", "open", "close"}:
                raise SpecError(path, "each needs exactly effector, open and close", field=f"constraints[{i}]")
            if not isinstance(c["effector"], str):
                raise SpecError(
                    path, f"constraint {i + 1}: the effector must be a joint name, got {_show(c['effector'])}",
                    field="constraints",
                )  # fmt: skip
            for key in ("open", "close"):
                if not _whole(c[key]) or not 0 <= c[key] <= LIMITS.frames:
                    raise SpecError(
                        path,
                        f"constraint on {c['effector']!r}: '{key}' must be a keytime index (a whole number ≥ 0), "
                        f"got {_show(c[key])}",
                        field="constraints",
                    )
    return {
        "path": path,
        "name": name,
        "floor": float(floor),
        "fps": None if fps is None else float(fps),
        "constraints": constraints,
        "keytime_spacing": spacing,
        "smoothing": rules["smoothing"],
        "shrinkage": rules["shrinkage"],
        "goal_chain": tuple(chain),
        "timing": timing,
        "encoding": encoding,
        "num_cp": num_cp,
        "cyclic": cyclic,
        "in_place": in_place,
        "skeleton": raw.get("skeleton"),
        "cut": raw.get("cut"),
        "adverbs": adverbs,
        "examples": examples,
    }


def _whole(v: object) -> bool:
    """A whole number, and not a boolean (TOML's ``true`` is no number here)."""
    return isinstance(v, int) and not isinstance(v, bool)


def _number(v: object) -> bool:
    """A finite number, and not a boolean."""
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def _show(v: object) -> str:
    """``v`` for a message, spelled as in the TOML file (``true``, ``nan``, ``[1, 2]``), shortened."""
    text = _spelled(v)
    return text if len(text) <= 60 else text[:57] + "..."


def _spelled(v: object) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v) if abs(v) < 10**30 else f"a {len(str(abs(v)))}-digit number"
    if isinstance(v, float) and not math.isfinite(v):
        return "nan" if math.isnan(v) else "inf" if v > 0 else "-inf"
    if isinstance(v, list):
        return "[" + ", ".join(_spelled(x) for x in v[:10]) + (", ...]" if len(v) > 10 else "]")
    if isinstance(v, dict):
        items = [f"{k} = {_spelled(x)}" for k, x in list(v.items())[:10]]
        return "{ " + ", ".join(items) + (", ... }" if len(v) > 10 else " }")
    return repr(v)


def _text(path: Path, table: dict, key: str, example: str | None, prefix: str = "") -> None:
    if key in table and not isinstance(table[key], str):
        raise SpecError(path, f"must be a string, got {_show(table[key])}", example, prefix + key)


def _cut(path: Path, cut: object, example: str | None) -> None:
    """Check a ``cut`` table's fields and their types (whether the file has those strikes is for later)."""
    if not isinstance(cut, dict):
        raise SpecError(path, 'must be a table such as { foot = "left", steps = 2 }', example, "cut")
    extra = sorted(set(cut) - CUT_FIELDS)
    if extra:
        raise SpecError(path, f"unknown field; cut takes {', '.join(sorted(CUT_FIELDS))}", example, f"cut.{extra[0]}")
    if "foot" in cut and cut["foot"] not in FEET:
        raise SpecError(path, f'must be "left" or "right", got {_show(cut["foot"])}', example, "cut.foot")
    strike = cut.get("strike", 0)
    if strike != "most_turning" and not (_whole(strike) and 0 <= strike <= LIMITS.frames):
        raise SpecError(
            path, f'must be a heel-strike index ≥ 0 or "most_turning", got {_show(strike)}', example, "cut.strike"
        )
    steps = cut.get("steps", 2)
    if not (_whole(steps) and 1 <= steps <= LIMITS.frames):
        raise SpecError(path, f"must be a whole number of steps ≥ 1, got {_show(steps)}", example, "cut.steps")
    if cut.get("events", "strikes") not in ("strikes", "contacts"):
        raise SpecError(path, f'must be "strikes" or "contacts", got {_show(cut["events"])}', example, "cut.events")


def _measure(path: Path, m: dict, field: str) -> None:
    """Check a measure table's types (whether its joint exists is for later, with the skeleton)."""
    if m.get("kind") not in MEASURES:
        raise SpecError(
            path, f"unknown measure {_show(m.get('kind'))}; measures are {', '.join(MEASURES)}", field=field
        )
    if "joint" in m and not isinstance(m["joint"], str):
        raise SpecError(path, f"joint must be a joint name, got {_show(m['joint'])}", field=field)
    if "axis" in m and m["axis"] not in ("x", "y", "z"):
        raise SpecError(path, f"axis must be 'x', 'y' or 'z', got {_show(m['axis'])}", field=field)
    if "keytime" in m and not (_whole(m["keytime"]) and 0 <= m["keytime"] <= LIMITS.frames):
        raise SpecError(
            path, f"keytime must be a keytime index (a whole number ≥ 0), got {_show(m['keytime'])}", field=field
        )


def _example(path: Path, ex: dict) -> None:
    """Check one example's fields and their types."""
    name = ex["name"]
    if "file" not in ex:
        raise SpecError(path, "missing", name, "file")
    if not isinstance(ex["file"], str):
        raise SpecError(path, f"must be a path (a string), got {_show(ex['file'])}", name, "file")
    _text(path, ex, "description", name)
    if "cut" in ex:
        _cut(path, ex["cut"], name)
    if "cut" in ex and "frames" in ex:
        raise SpecError(path, "give either 'cut' or 'frames', not both", name, "frames")
    if "frames" in ex:
        frames = ex["frames"]
        if not (
            isinstance(frames, list) and len(frames) == 2 and all(_whole(f) and abs(f) <= LIMITS.frames for f in frames)
        ):
            raise SpecError(path, f"must be [A, B] whole frame numbers, got {_show(frames)}", name, "frames")
    if "keytimes" in ex:
        given = ex["keytimes"]
        if isinstance(given, dict):
            if set(given) != {"peak"} or not isinstance(given["peak"], str):
                raise SpecError(path, 'takes { peak = "JOINT" }', name, "keytimes")
        elif not isinstance(given, list) or not all(_number(v) for v in given):
            raise SpecError(path, f"must be a list of seconds (finite numbers), got {_show(given)}", name, "keytimes")
    for flag in ("mirror", "refine"):
        if not isinstance(ex.get(flag, False), bool):
            raise SpecError(path, "must be true or false", name, flag)
    given = ex.get("adverbs", {})
    if not isinstance(given, dict):
        raise SpecError(path, "must be a table of adverb values", name, "adverbs")
    for key, value in given.items():
        if not (_number(value) and abs(value) <= ADVERB_LIMIT):
            raise SpecError(
                path, f"must be a finite number within ±{ADVERB_LIMIT:g}, got {_show(value)}", name, f"adverbs.{key}"
            )


def _unknown(path: Path, table: dict, allowed: set[str], example: str | None, prefix: str = "") -> None:
    extra = sorted(set(table) - allowed)
    if extra:
        field = f"{prefix}.{extra[0]}" if prefix else extra[0]
        raise SpecError(path, f"unknown field; fields here are {', '.join(sorted(allowed))}", example, field)
