"""Timed scripts (TOML): which creatures stand where, and at what time each is told to do what.

::

    seconds = 20                       # how long the run lasts (the command line may say otherwise)
    graphs = ["../graphs/cmu.toml"]    # more graphs than the command line's, relative to this file

    [[creatures]]
    name = "hero"
    graph = "bandai"                   # a graph's name (default: the first graph)
    at = [0.0, 0.0]                    # x, z in metres
    heading = 0                        # degrees, 0 facing +z, positive turning left
    verb = "idle"                      # what it starts in (default: the graph's start)
    adverbs = { valence = 0.5 }

    [[cues]]
    at = 1.0                           # seconds
    creature = "hero"                  # may be left out when there is one creature
    perform = "walk"                   # a verb, through the graph's planner
    stay = true                        # keep playing it until the next cue (default)
    adverbs = { valence = 0.8, turn = 30 }
    over = 1.0                         # seconds to ease the adverbs in (default: as the change needs, 0.5-3)

A malformed script — not TOML, over 1 MiB, a field of the wrong type, an unknown field or creature, a cue with
nothing to do, a creature placed more than 10 km from the origin (where floors end) or turned past ±360° — is
refused as it loads, naming the file, the line and the field. A cue the graph cannot carry out
(an unknown verb or adverb, a value out of range) is refused when its time comes, naming its line; the
run goes on.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import AdverbsError
from ..kinematics.floor import LEVEL_LIMIT
from ..verb.spec import read_toml_text
from .simulation import Simulation

CREATURE_FIELDS = {"name", "graph", "at", "heading", "verb", "adverbs"}
CUE_FIELDS = {"at", "creature", "perform", "stay", "adverbs", "over"}
TOP_FIELDS = {"seconds", "graphs", "creatures", "cues", "fps", "seed"}
PLACE_LIMIT = LEVEL_LIMIT  # metres from the origin a creature may start at: the floor's bound (10 km)


class ScriptError(AdverbsError):
    """A script that cannot run: ``path``, ``line`` (1-based, 0 when unknown) and ``field`` say where."""

    def __init__(self, path: str | Path, line: int, field: str, reason: str):
        self.path, self.line, self.field = str(path), int(line), field
        where = f"{path}, line {line}" if line else str(path)
        super().__init__(f"{where}: {field + ': ' if field else ''}{reason}")


@dataclass
class CreatureSpec:
    name: str
    graph: str | None = None
    at: tuple[float, float] = (0.0, 0.0)
    heading: float = 0.0
    verb: str | None = None
    adverbs: dict[str, float] = field(default_factory=dict)
    line: int = 0


@dataclass
class CueSpec:
    at: float
    creature: str
    perform: str | None = None
    stay: bool = True
    adverbs: dict[str, float] = field(default_factory=dict)
    over: float | None = None
    line: int = 0


@dataclass
class Script:
    """A loaded script: ``creatures``, ``cues`` in time order, ``seconds`` (None: not said), extra ``graphs``
    (paths), ``fps`` and ``seed`` when it says, and where it came from."""

    path: str
    creatures: list[CreatureSpec]
    cues: list[CueSpec]
    seconds: float | None = None
    graphs: list[Path] = field(default_factory=list)
    fps: float | None = None
    seed: int | None = None

    def apply(self, sim: Simulation) -> None:
        """Add the script's creatures to ``sim`` and queue its cues."""
        made = {}
        for c in self.creatures:
            try:
                made[c.name] = sim.add_creature(c.at, c.heading, c.graph, c.name, c.verb, c.adverbs or None)
            except AdverbsError as e:
                raise ScriptError(self.path, c.line, f"creature {c.name!r}", str(e)) from None
        for cue in self.cues:
            creature = made[cue.creature]
            source = f"{self.path}, line {cue.line}"
            if cue.adverbs:
                sim._command(creature, "adverbs", {"adverbs": cue.adverbs, "over": cue.over}, cue.at, source)
            if cue.perform is not None:
                sim._command(creature, "perform", {"verb": cue.perform, "stay": cue.stay}, cue.at, source)


def _headers(text: str, name: str) -> list[int]:
    """Line numbers (1-based) of each ``[[name]]`` table header in ``text``."""
    pattern = re.compile(rf"^\s*\[\[\s*{re.escape(name)}\s*\]\]")
    return [i + 1 for i, line in enumerate(text.splitlines()) if pattern.match(line)]


def _field_line(text: str, start: int, key: str) -> int:
    """The line of ``key = ...`` in the table whose header is on line ``start`` (the header's line if not found)."""
    lines = text.splitlines()
    pattern = re.compile(rf"^\s*{re.escape(key)}\s*=")
    for i in range(start, len(lines)):
        if lines[i].lstrip().startswith("["):
            break
        if pattern.match(lines[i]):
            return i + 1
    return start


def _number(value, path, line, name, low=-math.inf, high=math.inf, unit: str = "") -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) or not low <= value <= high:
        unit = f" {unit}" if unit else ""
        raise ScriptError(path, line, name, f"must be a number from {low:g} to {high:g}{unit}, got {value!r}")
    return float(value)


def _adverbs(value, path, line, name) -> dict[str, float]:
    if not isinstance(value, dict):
        raise ScriptError(path, line, name, f"must be a table of adverb = number, got {value!r}")
    out = {}
    for k, x in value.items():
        if isinstance(x, bool) or not isinstance(x, int | float):
            raise ScriptError(path, line, f"{name}.{k}", f"must be a number, got {x!r}")
        out[str(k)] = float(x)  # NaN and values out of range are the graph's to refuse, when the cue runs
    return out


def _toml_error(path: Path, reason: str) -> ScriptError:
    """:func:`~adverbs.verb.spec.read_toml_text`'s refusal as a script's, on the line the TOML reader names."""
    m = re.search(r"line (\d+)", reason)
    return ScriptError(path, int(m.group(1)) if m else 0, "", reason)


def load_script(path: str | Path) -> Script:
    """Read and check a script (see the module); raises :class:`ScriptError` naming the line and field."""
    path = Path(path)
    data, text = read_toml_text(path, "script", _toml_error)  # at most 1 MiB, and TOML that cannot exhaust the reader
    for k in data:
        if k not in TOP_FIELDS:
            raise ScriptError(path, _field_line(text, 0, k), k, f"unknown field; a script has {', '.join(sorted(TOP_FIELDS))}")
    seconds = None if "seconds" not in data else _number(data["seconds"], path, _field_line(text, 0, "seconds"), "seconds", 1e-3, 24 * 3600)
    fps = None if "fps" not in data else _number(data["fps"], path, _field_line(text, 0, "fps"), "fps", 1, 1000)
    seed = data.get("seed")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int) or seed < 0):
        raise ScriptError(path, _field_line(text, 0, "seed"), "seed", f"must be a whole number ≥ 0, got {seed!r}")
    graphs = data.get("graphs", [])
    if not isinstance(graphs, list) or not all(isinstance(g, str) for g in graphs):
        raise ScriptError(path, _field_line(text, 0, "graphs"), "graphs", "must be a list of graph spec paths")
    creatures = _creatures(data.get("creatures", []), text, path)
    cues = _cues(data.get("cues", []), text, path, creatures)
    return Script(str(path), creatures, cues, seconds, [path.parent / g for g in graphs], fps, seed)


def _tables(value, text, path, name, fields, what):
    """Each ``[[name]]`` entry checked for unknown fields: ``(index, table, header line, where, at_line)``, where
    ``at_line(key)`` is the line of that key in the entry (0 when unknown)."""
    if not isinstance(value, list) or not all(isinstance(t, dict) for t in value):
        raise ScriptError(path, _field_line(text, 0, name), name, f"must be tables ([[{name}]]), got {value!r}")
    lines = _headers(text, name)
    for i, t in enumerate(value):
        line = lines[i] if i < len(lines) else 0
        where = f"{name}[{i}]"
        at_line = lambda k, line=line: _field_line(text, line, k) if line else 0  # noqa: E731
        for k in t:
            if k not in fields:
                raise ScriptError(path, at_line(k), f"{where}.{k}", f"unknown field; {what} has {', '.join(sorted(fields))}")
        yield i, t, line, where, at_line


def _creatures(value, text, path) -> list[CreatureSpec]:
    out: list[CreatureSpec] = []
    for i, t, line, where, at_line in _tables(value, text, path, "creatures", CREATURE_FIELDS, "a creature"):
        name = t.get("name", f"creature{i + 1}")
        if not isinstance(name, str) or not name or not re.fullmatch(r"[\w.-]+", name):
            raise ScriptError(path, at_line("name"), f"{where}.name", f"must be a name of letters, digits, '_', '.' or '-', got {name!r}")
        if any(c.name == name for c in out):
            raise ScriptError(path, at_line("name"), f"{where}.name", f"{name!r} is the name of an earlier creature")
        at = t.get("at", [0.0, 0.0])
        if not isinstance(at, list) or len(at) != 2:
            raise ScriptError(path, at_line("at"), f"{where}.at", f"must be [x, z] in metres, got {at!r}")
        xz = tuple(_number(a, path, at_line("at"), f"{where}.at[{k}]", -PLACE_LIMIT, PLACE_LIMIT, "metres") for k, a in enumerate(at))  # fmt: skip
        heading = _number(t.get("heading", 0.0), path, at_line("heading"), f"{where}.heading", -360.0, 360.0, "degrees")
        for k in ("graph", "verb"):
            if k in t and not isinstance(t[k], str):
                raise ScriptError(path, at_line(k), f"{where}.{k}", f"must be a name, got {t[k]!r}")
        adverbs = _adverbs(t.get("adverbs", {}), path, at_line("adverbs"), f"{where}.adverbs")
        out.append(CreatureSpec(name, t.get("graph"), xz, heading, t.get("verb"), adverbs, line))
    return out or [CreatureSpec("creature1")]


def _cues(value, text, path, creatures: list[CreatureSpec]) -> list[CueSpec]:
    names = [c.name for c in creatures]
    out = []
    for _, t, line, where, at_line in _tables(value, text, path, "cues", CUE_FIELDS, "a cue"):
        if "at" not in t:
            raise ScriptError(path, line, f"{where}.at", "missing: when the cue runs, in seconds")
        at = _number(t["at"], path, at_line("at"), f"{where}.at", 0.0, 24 * 3600)
        creature = t.get("creature", names[0] if len(names) == 1 else None)
        if creature is None:
            raise ScriptError(path, line, f"{where}.creature", f"missing: which creature ({', '.join(names)})")
        if creature not in names:
            raise ScriptError(path, at_line("creature"), f"{where}.creature", f"no creature {creature!r}; the script has {', '.join(names)}")
        perform = t.get("perform")
        if perform is not None and not isinstance(perform, str):
            raise ScriptError(path, at_line("perform"), f"{where}.perform", f"must be a verb's name, got {perform!r}")
        stay = t.get("stay", True)
        if not isinstance(stay, bool):
            raise ScriptError(path, at_line("stay"), f"{where}.stay", f"must be true or false, got {stay!r}")
        adverbs = _adverbs(t.get("adverbs", {}), path, at_line("adverbs"), f"{where}.adverbs")
        over = None if "over" not in t else _number(t["over"], path, at_line("over"), f"{where}.over", 0.0, 3600.0)
        if perform is None and not adverbs:
            raise ScriptError(path, line, where, "a cue does something: give it perform = VERB or adverbs = { ... }")
        out.append(CueSpec(at, creature, perform, stay, adverbs, over, line))
    return sorted(out, key=lambda c: c.at)
