"""Dataset spec files (TOML): which verbs and graphs, how their adverb points are drawn, how long, on what floors,
in which formats. Read and checked whole before any work (no verb built, no cluster started).

```toml
name = "verbs-10k"               # optional (default: the file's name)
seed = 0                         # every clip's seed derives from it and the clip's id
formats = ["arrays", "bvh"]      # any of "arrays" (NumPy .npz per shard), "bvh", "glb"
shard_size = 100                 # clips per shard: the unit of work, of output and of resuming
fps = 30                         # optional: default each verb's own (graphs: 30)
floors = ["flat", "slope:5"]     # optional: each clip draws one ("flat" = the verb's own floor, "flat:LEVEL", "slope:DEG")
portable = false                 # BVH with position channels on the root only (see adverbs convert --portable)

[[verbs]]
spec = "../specs/cmu_walk.toml"  # a verb spec (built once, before any clip), or
# verb = "../out/cmu_walk.verb"  # a built verb file
clips = 1000
sampler = "sobol"                # "grid", "uniform", "sobol", "lhs" (Latin hypercube) or "points"
margin = 0.1                     # the examples' range widened by this much of it on each side
duration = [2.0, 4.0]            # seconds, or [shortest, longest] drawn per clip (default: one cycle)
loop = "graph"                   # past one cycle: each into the next by the verb's own loop, as adverbs synth does
                                 # (default), or "kernel": Verb.synthesize's faded seams (a little faster)
# grid = 5                       # sampler = "grid": values per adverb (clips = grid ** adverbs)
# points = [{ speed = 1.2, turn = 0 }]   # sampler = "points": these adverb points (clips: repeats of them)

[[graphs]]
graph = "../graphs/cmu.toml"
clips = 200
sampler = "uniform"              # where each performance's adverbs start (margin at most 0.5: the graph's reach)
duration = 8.0                   # seconds of performance (default 10)
every = [2.0, 5.0]               # a random command every 2-5 s: a verb of the graph, drawn uniformly
change_adverbs = true            # each command also draws new adverbs (default true)
start = "walk"                   # optional: the verb every performance starts in
```

Paths are relative to the spec file. Every mistake is a :class:`DatasetSpecError` naming the file and the field.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import AdverbsError
from ..graph.performance import MAX_SECONDS
from ..graph.structure import REACH
from ..verb.spec import read_toml

SAMPLERS = ("grid", "uniform", "sobol", "lhs", "points")
FORMATS = ("arrays", "bvh", "glb")
MAX_CLIPS = 100_000_000  # clips in one dataset: far past any use; a typo of many zeros is refused
MAX_SHARD = 100_000
MAX_MARGIN = 10.0  # ranges past the examples: farther, the motion degenerates (a verb refuses it clip by clip)
MAX_FPS = 1000.0
DEFAULT_GRAPH_SECONDS = 10.0
DEFAULT_GRAPH_FPS = 30.0

_TOP = {"name", "description", "seed", "formats", "shard_size", "fps", "floors", "portable", "verbs", "graphs"}
_COMMON = {"clips", "sampler", "margin", "duration", "grid", "points", "description", "name"}
_VERB = _COMMON | {"spec", "verb", "loop"}
LOOPS = ("graph", "kernel")
_GRAPH = _COMMON | {"graph", "every", "change_adverbs", "start"}


class DatasetSpecError(AdverbsError):
    """A mistake in a dataset spec; ``path`` and ``field`` (e.g. ``"verbs[2].sampler"``) say where."""

    def __init__(self, path: Path | str, reason: str, field: str | None = None):
        self.path, self.field, self.reason = str(path), field, reason
        where = str(path) if field is None else f"{path}: field '{field}'"
        super().__init__(f"{where}: {reason}")


@dataclass(frozen=True)
class Entry:
    """One ``[[verbs]]`` or ``[[graphs]]`` entry: a source (``kind`` "verb" or "graph", ``file`` and whether it is a
    ``built`` verb file rather than a spec) and how its clips are drawn."""

    kind: str
    file: Path
    built: bool
    where: str  # "verbs[1]": for messages
    clips: int | None
    sampler: str
    margin: float
    duration: tuple[float, float] | None  # seconds, shortest and longest (equal: fixed); None: one cycle
    grid: int | None = None
    points: tuple[dict[str, float], ...] = ()
    every: tuple[float, float] = (2.0, 5.0)
    change_adverbs: bool = True
    start: str | None = None
    name: str | None = None
    loop: str = "graph"


@dataclass(frozen=True)
class DatasetSpec:
    """A dataset spec, checked: see the module's docstring."""

    path: Path
    name: str
    seed: int
    formats: tuple[str, ...]
    shard_size: int
    fps: float | None
    floors: tuple[str, ...]
    portable: bool
    entries: tuple[Entry, ...] = field(default_factory=tuple)


def _fail(path: Path, reason: str, where: str | None) -> DatasetSpecError:
    return DatasetSpecError(path, reason, where)


def _unknown(path: Path, table: dict, allowed: set[str], where: str | None) -> None:
    for key in table:
        if key not in allowed:
            raise _fail(path, f"unknown field; the fields here are {', '.join(sorted(allowed))}", key if where is None else f"{where}.{key}")


def _number(path: Path, x: Any, where: str, low: float = -math.inf, high: float = math.inf, above: bool = False) -> float:
    """A finite number in ``[low, high]`` (``above``: strictly above ``low``)."""
    if isinstance(x, bool) or not isinstance(x, int | float):
        raise _fail(path, f"must be a number, got {x!r}", where)
    v = float(x)
    if not math.isfinite(v):
        raise _fail(path, f"must be a finite number, got {v}", where)
    if v < low or (above and v <= low) or v > high:
        side = f"above {low:g}" if above else f"at least {low:g}"
        raise _fail(path, f"must be a number {side}" + (f" and at most {high:g}" if high < math.inf else "") + f", got {v:g}", where)
    return v


def _integer(path: Path, x: Any, where: str, low: int, high: int) -> int:
    if isinstance(x, bool) or not isinstance(x, int):
        raise _fail(path, f"must be a whole number, got {x!r}", where)
    if not low <= x <= high:
        raise _fail(path, f"must be from {low:,} to {high:,}, got {x:,}", where)
    return x


def _boolean(path: Path, x: Any, where: str) -> bool:
    if not isinstance(x, bool):
        raise _fail(path, f"must be true or false, got {x!r}", where)
    return x


def _range(path: Path, x: Any, where: str, low: float, high: float) -> tuple[float, float]:
    """A number or ``[shortest, longest]``, each above ``low`` and at most ``high``."""
    if isinstance(x, list):
        if len(x) != 2:
            raise _fail(path, f"must be a number or [shortest, longest], got {x!r}", where)
        a, b = (_number(path, v, where, low, high, above=True) for v in x)
        if a > b:
            raise _fail(path, f"[shortest, longest] in order, got [{a:g}, {b:g}]", where)
        return a, b
    v = _number(path, x, where, low, high, above=True)
    return v, v


def _floor(path: Path, x: Any, where: str) -> str:
    if not isinstance(x, str):
        raise _fail(path, f"must be a floor (\"flat\", \"flat:LEVEL\" or \"slope:DEGREES\"), got {x!r}", where)
    kind, _, value = x.partition(":")
    if kind not in ("flat", "slope") or (kind == "slope" and not value):
        raise _fail(path, f"unknown floor {x!r}; floors are \"flat\", \"flat:LEVEL\" (metres) and \"slope:DEGREES\"", where)
    if value:
        try:
            number = float(value)
        except ValueError:
            raise _fail(path, f"floor {x!r}: {value!r} is not a number", where) from None
        limit = 80.0 if kind == "slope" else 1e4
        if not (math.isfinite(number) and abs(number) <= limit):
            raise _fail(path, f"floor {x!r}: must be within ±{limit:g}", where)
    return x


def load_dataset_spec(path: str | Path) -> DatasetSpec:
    """Read and check a dataset spec; every mistake is a :class:`DatasetSpecError` naming the file and the field."""
    path = Path(path)
    raw = read_toml(path, "dataset spec", DatasetSpecError)
    _unknown(path, raw, _TOP, None)
    name = raw.get("name", path.stem)
    if not isinstance(name, str) or not name:
        raise _fail(path, f"must be a name (a string), got {name!r}", "name")
    seed = _integer(path, raw.get("seed", 0), "seed", 0, 2**63 - 1)
    formats = raw.get("formats", ["arrays"])
    if isinstance(formats, str):
        formats = [formats]
    if not isinstance(formats, list) or not formats:
        raise _fail(path, f"must be a list of formats ({', '.join(FORMATS)}), got {formats!r}", "formats")
    for f in formats:
        if f not in FORMATS:
            raise _fail(path, f"unknown format {f!r}; the formats are {', '.join(FORMATS)}", "formats")
    if len(set(formats)) != len(formats):
        raise _fail(path, f"a format is listed twice: {formats!r}", "formats")
    shard = _integer(path, raw.get("shard_size", 100), "shard_size", 1, MAX_SHARD)
    fps = _number(path, raw["fps"], "fps", 1.0, MAX_FPS) if "fps" in raw else None
    floors = raw.get("floors", ["flat"])
    if not isinstance(floors, list) or not floors:
        raise _fail(path, f"must be a list of floors, got {floors!r}", "floors")
    floors = tuple(_floor(path, f, f"floors[{i + 1}]") for i, f in enumerate(floors))
    portable = _boolean(path, raw.get("portable", False), "portable")
    entries = []
    for kind, fields, key in (("verb", _VERB, "verbs"), ("graph", _GRAPH, "graphs")):
        listed = raw.get(key, [])
        if not isinstance(listed, list):
            raise _fail(path, f"must be a list of [[{key}]] tables", key)
        for i, table in enumerate(listed):
            entries.append(_entry(path, kind, table, fields, f"{key}[{i + 1}]"))
    if not entries:
        raise _fail(path, "a dataset needs at least one [[verbs]] or [[graphs]] entry", "verbs")
    return DatasetSpec(path, name, seed, tuple(formats), shard, fps, floors, portable, tuple(entries))


def _entry(path: Path, kind: str, table: Any, fields: set[str], where: str) -> Entry:
    if not isinstance(table, dict):
        raise _fail(path, "must be a table", where)
    _unknown(path, table, fields, where)
    keys = ("spec", "verb") if kind == "verb" else ("graph",)
    given = [k for k in keys if k in table]
    if len(given) != 1:
        what = "one of spec (a verb spec file) or verb (a built verb file)" if kind == "verb" else "graph (a graph spec file)"
        raise _fail(path, f"give {what}", where)
    key = given[0]
    if not isinstance(table[key], str):
        raise _fail(path, "must be a path (a string)", f"{where}.{key}")
    file = (path.parent / table[key]).resolve()
    if not file.is_file():
        raise _fail(path, f"no such file: {file}", f"{where}.{key}")
    sampler = table.get("sampler", "uniform")
    if sampler not in SAMPLERS:
        raise _fail(path, f"unknown sampler {sampler!r}; the samplers are {', '.join(SAMPLERS)}", f"{where}.sampler")
    margin_limit = REACH if kind == "graph" else MAX_MARGIN
    margin = _number(path, table.get("margin", 0.0), f"{where}.margin", 0.0, margin_limit)
    grid, points, clips = None, (), None
    if sampler == "grid":
        if "grid" not in table:
            raise _fail(path, "sampler \"grid\" needs grid = values per adverb", f"{where}.grid")
        grid = _integer(path, table["grid"], f"{where}.grid", 1, 10_000)
    elif "grid" in table:
        raise _fail(path, f"grid is for sampler \"grid\", not {sampler!r}", f"{where}.grid")
    if sampler == "points":
        listed = table.get("points")
        if not isinstance(listed, list) or not listed:
            raise _fail(path, "sampler \"points\" needs points = [{ adverb = value, ... }, ...]", f"{where}.points")
        out = []
        for j, p in enumerate(listed):
            if not isinstance(p, dict):
                raise _fail(path, f"must be a table of adverb = value, got {p!r}", f"{where}.points[{j + 1}]")
            out.append({str(k): _number(path, v, f"{where}.points[{j + 1}].{k}") for k, v in p.items()})
        points = tuple(out)
    elif "points" in table:
        raise _fail(path, f"points are for sampler \"points\", not {sampler!r}", f"{where}.points")
    if "clips" in table:
        if sampler == "grid":
            raise _fail(path, "sampler \"grid\" makes grid ** adverbs clips: give grid, not clips", f"{where}.clips")
        clips = _integer(path, table["clips"], f"{where}.clips", 1, MAX_CLIPS)
    elif sampler != "grid" and sampler != "points":
        raise _fail(path, "how many clips to make (a whole number)", f"{where}.clips")
    duration = None
    if "duration" in table:
        duration = _range(path, table["duration"], f"{where}.duration", 0.0, MAX_SECONDS)
    elif kind == "graph":
        duration = (DEFAULT_GRAPH_SECONDS, DEFAULT_GRAPH_SECONDS)
    every, change, start = (2.0, 5.0), True, None
    if kind == "graph":
        if "every" in table:
            every = _range(path, table["every"], f"{where}.every", 0.0, MAX_SECONDS)
        change = _boolean(path, table.get("change_adverbs", True), f"{where}.change_adverbs")
        start = table.get("start")
        if start is not None and not isinstance(start, str):
            raise _fail(path, f"must be a verb's name, got {start!r}", f"{where}.start")
    name = table.get("name")
    if name is not None and (not isinstance(name, str) or not name):
        raise _fail(path, f"must be a name (a string), got {name!r}", f"{where}.name")
    loop = table.get("loop", "graph")
    if loop not in LOOPS:
        raise _fail(path, f"unknown loop {loop!r}; the loops are {', '.join(LOOPS)}", f"{where}.loop")
    return Entry(kind, file, key == "verb", where, clips, sampler, margin, duration, grid, points, every, change, start, name, loop)
