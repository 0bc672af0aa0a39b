"""Verb spec files (TOML): what an animator writes by hand to make a verb.

```toml
name = "walk"
encoding = "logquat"          # or "euler" (the paper's channels)
num_cp = 12                   # B-spline control points per DOF (NumCP)
cyclic = true                 # a cycle (walk) or a one-shot motion (reach)
skeleton = "data/x.bvh"       # optional: every example must be on this skeleton
cut = { foot = "left", steps = 2 }   # default part of each file: one cycle from a left heel strike
fps = 30                      # optional: resample every example to this rate (needed when files differ)
keytime_spacing = "examples"  # keytimes in generic time spaced as the examples' are; "even": the paper's
smoothing = 0                 # interpolation: 0 exact (the paper's); a number or "auto" to approximate
shrinkage = 0                 # shrink the linear part's slopes: 0 (default), a number or "auto"

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

This module reads and checks the TOML (:func:`load_spec`); :mod:`.examples` reads, cuts and measures
the examples it names, and :func:`adverbs.verb.fit.build_from_spec` builds the verb.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..errors import AdverbsError
from ..motion.encoding import KINDS
from .measures import MEASURES

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
    "keytime_spacing",
    "smoothing",
    "shrinkage",
}
_ADVERB = {"name", "unit", "measure", "description"}
_EXAMPLE = {"name", "file", "cut", "frames", "keytimes", "mirror", "adverbs", "refine", "description"}
CUT_FIELDS = {"foot", "strike", "steps", "events"}


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
    """The table in TOML file ``path`` (a ``kind``: "spec", "graph"); what goes wrong is ``error(path, reason)``."""
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise error(path, f"no such {kind} file") from None
    except UnicodeDecodeError:
        raise error(path, "not a text file (UTF-8)") from None
    except OSError as e:
        raise error(path, f"cannot read: {e.strerror}") from None
    except tomllib.TOMLDecodeError as e:
        raise error(path, f"not valid TOML: {e}") from None


def load_spec(path: str | Path) -> dict[str, Any]:
    """Parse and check a spec's structure (types, names, fields); does not read the BVH files."""
    path = Path(path)
    raw = read_toml(path, "spec", SpecError)
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
    spacing = raw.get("keytime_spacing", "examples")
    if spacing not in ("examples", "even"):
        raise SpecError(path, f'must be "examples" or "even", got {spacing!r}', field="keytime_spacing")
    rules = {}
    for key in ("smoothing", "shrinkage"):
        v = raw.get(key, 0.0)
        if v != "auto" and (isinstance(v, bool) or not isinstance(v, int | float) or not (math.isfinite(v) and v >= 0)):
            raise SpecError(path, f'must be a number ≥ 0 or "auto", got {v!r}', field=key)
        rules[key] = v if v == "auto" else float(v)
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
        "keytime_spacing": spacing,
        "smoothing": rules["smoothing"],
        "shrinkage": rules["shrinkage"],
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
