"""Graph spec files (TOML): the verbs, the adverbs they share, and the transitions between them.

```toml
name = "bandai"
start = "idle"                        # optional: the verb creatures start in (default: the first)
adverbs = { valence = 0.0, turn = 0 } # optional: where shared adverbs start (default: the examples' mean)

[[verbs]]
name = "walk"                         # optional: the verb's own name
spec = "bandai_styled_walk.toml"      # a verb spec (built when the graph is loaded), or
# verb = "../out/walk.verb"           # a built verb file
adverbs = { energy = "mood" }        # optional: read the graph adverb "mood" for the verb's "energy"
clamp = false                         # true: the verb plays at its adverbs kept inside its examples' ranges
loop_likelihood = 3                   # cyclic verbs: likelihood of the loop into itself the graph adds

[[transitions]]
from = "idle"
to = "walk"
from_region = [0.6, 1.0]              # generic time of "idle" where the blend runs
to_region = [0.0, 0.25]               # generic time of "walk"
likelihood = 1                        # > 0: weight among the ways out of "idle" when nothing is asked
blend = "cosine"                      # or "inertial": start "walk" at once, decay the pose difference
interruptible = true                  # a new command during it starts from the current pose at once
                                      # (a stop, a cycle into a one-shot, always ends first)
```

A verb of one example (a bow, a wave) is a verb spec with one ``[[examples]]`` entry and no adverbs.
Paths are relative to the graph file. Every mistake raises :class:`GraphSpecError` naming the file and
the field: an unknown verb, a region outside ``[0, 1]`` or empty, verbs on different skeletons, a verb
with no way out, a likelihood (of a transition or a verb's loop) that is not a positive number up to 1e6.
"""

from __future__ import annotations

import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path
from typing import Any

from ..errors import AdverbsError, AdverbsWarning
from ..verb.fit import build_from_spec
from ..verb.spec import read_toml
from ..verb.store import load_verb
from .structure import BLENDS, Graph, Transition, GraphError, check_transition

_TOP = {"name", "description", "start", "adverbs", "verbs", "transitions"}
_VERB = {"name", "spec", "verb", "adverbs", "clamp", "loop_likelihood", "description"}
_TRANSITION = {"from", "to", "from_region", "to_region", "likelihood", "blend", "interruptible", "description"}
MAX_LIKELIHOOD = 1e6  # likelihoods are relative weights: a million times another is past any meaning


class GraphSpecError(AdverbsError):
    """A mistake in a graph spec; ``path`` and ``field`` say where."""

    def __init__(self, path: Path | str, reason: str, field: str | None = None):
        self.path, self.field, self.reason = str(path), field, reason
        where = str(path) if field is None else f"{path}: field '{field}'"
        super().__init__(f"{where}: {reason}")


def _unknown(path: Path, table: dict, allowed: set[str], where: str | None) -> None:
    for key in table:
        if key not in allowed:
            field = key if where is None else f"{where}.{key}"
            raise GraphSpecError(path, f"unknown field; the fields here are {', '.join(sorted(allowed))}", field)


def _number(path: Path, x: Any, field: str) -> float:
    if isinstance(x, bool) or not isinstance(x, int | float):
        raise GraphSpecError(path, f"must be a number, got {x!r}", field)
    return float(x)


def _likelihood(path: Path, x: Any, field: str) -> float:
    """A likelihood, a weight among the ways out of a verb, up to :data:`MAX_LIKELIHOOD`: weights near the largest
    float sum to infinity, and the chances to NaN (zero, negative and NaN ones are the caller's to refuse)."""
    value = _number(path, x, field)
    if value > MAX_LIKELIHOOD:
        raise GraphSpecError(path, f"must be a positive number up to {MAX_LIKELIHOOD:g} (a weight among the ways out of a verb), got {value:g}", field)  # fmt: skip
    return value


def load_graph(path: str | Path, progress: bool = False) -> Graph:
    """Read a graph spec, build (or read) its verbs and check the graph; ``progress`` prints each verb as it is built."""
    path = Path(path)
    raw = read_toml(path, "graph", GraphSpecError)
    _unknown(path, raw, _TOP, None)
    entries = raw.get("verbs")
    if not isinstance(entries, list) or not entries:
        raise GraphSpecError(path, "a graph needs at least one [[verbs]] entry", "verbs")
    verbs, loops, names, clamps = [], [], [], []
    for i, entry in enumerate(entries):
        where = f"verbs[{i + 1}]"
        if not isinstance(entry, dict):
            raise GraphSpecError(path, "must be a table", where)
        _unknown(path, entry, _VERB, where)
        if ("spec" in entry) == ("verb" in entry):
            raise GraphSpecError(path, "give one of spec (a verb spec file) or verb (a built verb file)", where)
        key = "spec" if "spec" in entry else "verb"
        if not isinstance(entry[key], str):
            raise GraphSpecError(path, "must be a path (a string)", f"{where}.{key}")
        file = (path.parent / entry[key]).resolve()
        started = time.perf_counter()
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", AdverbsWarning)
                verb = build_from_spec(file) if key == "spec" else load_verb(file)
        except AdverbsError as e:
            raise GraphSpecError(path, str(e), f"{where}.{key}") from None
        if progress:
            how = "built" if key == "spec" else "read"
            print(f"  {how} verb {verb.name!r} from {entry[key]} in {time.perf_counter() - started:.1f} s", file=sys.stderr)
            for w in caught:
                print(f"    warning: {w.message}", file=sys.stderr)
        name = entry.get("name", verb.name)
        if not isinstance(name, str) or not name:
            raise GraphSpecError(path, f"must be a name (a string), got {name!r}", f"{where}.name")
        if name in names:
            raise GraphSpecError(path, f"two verbs are named {name!r}", f"{where}.name")
        renames = entry.get("adverbs", {})
        if not isinstance(renames, dict) or not all(isinstance(x, str) for x in renames.values()):
            raise GraphSpecError(path, 'must be a table of the verb\'s adverb = "graph adverb"', f"{where}.adverbs")
        for a in renames:
            if a not in verb.adverb_names:
                raise GraphSpecError(
                    path, f"verb {name!r} has no adverb {a!r}; its adverbs are {', '.join(verb.adverb_names) or 'none'}", f"{where}.adverbs"
                )
        if name != verb.name or renames:
            adverbs = tuple(replace(a, name=renames.get(a.name, a.name)) for a in verb.adverbs)
            verb = replace(verb, name=name, adverbs=adverbs)
        why = verbs[0].skeleton.structure_difference(verb.skeleton) if verbs else None
        if why is not None:
            raise GraphSpecError(path, f"verb {name!r} is on a different skeleton from verb {names[0]!r}: {why}", f"{where}.{key}")
        loop = _likelihood(path, entry.get("loop_likelihood", 1.0), f"{where}.loop_likelihood")
        if not loop > 0:
            raise GraphSpecError(path, f"must be a positive number, got {loop:g}", f"{where}.loop_likelihood")
        clamp = entry.get("clamp", False)
        if not isinstance(clamp, bool):
            raise GraphSpecError(path, f"must be true or false, got {clamp!r}", f"{where}.clamp")
        verbs.append(verb)
        clamps.append(clamp)
        loops.append(loop)
        names.append(name)

    def verb_named(x: Any, field: str) -> int:
        if not isinstance(x, str) or x not in names:
            raise GraphSpecError(path, f"unknown verb {x!r}; the graph's verbs are {', '.join(names)}", field)
        return names.index(x)

    transitions = []
    entries = raw.get("transitions", [])
    if not isinstance(entries, list):
        raise GraphSpecError(path, "must be a list of [[transitions]] tables", "transitions")
    for i, entry in enumerate(entries):
        where = f"transitions[{i + 1}]"
        if not isinstance(entry, dict):
            raise GraphSpecError(path, "must be a table", where)
        _unknown(path, entry, _TRANSITION, where)
        for key in ("from", "to", "from_region", "to_region"):
            if key not in entry:
                raise GraphSpecError(path, "missing", f"{where}.{key}")
        a, b = verb_named(entry["from"], f"{where}.from"), verb_named(entry["to"], f"{where}.to")
        regions = []
        for key in ("from_region", "to_region"):
            r = entry[key]
            if not (isinstance(r, list) and len(r) == 2):
                raise GraphSpecError(path, f"must be [start, end] in generic time, got {r!r}", f"{where}.{key}")
            regions.append(tuple(_number(path, x, f"{where}.{key}") for x in r))
        blend = entry.get("blend", "cosine")
        if blend not in BLENDS:
            raise GraphSpecError(path, f"must be one of {', '.join(BLENDS)}, got {blend!r}", f"{where}.blend")
        interruptible = entry.get("interruptible", True)
        if not isinstance(interruptible, bool):
            raise GraphSpecError(path, f"must be true or false, got {interruptible!r}", f"{where}.interruptible")
        t = Transition(a, b, regions[0], regions[1], _likelihood(path, entry.get("likelihood", 1.0), f"{where}.likelihood"), blend, interruptible)
        try:
            check_transition(t, verbs)
        except GraphError as e:
            raise GraphSpecError(path, str(e), f"{where}.{e.field}") from None
        transitions.append(t)
    defaults = raw.get("adverbs", {})
    if not isinstance(defaults, dict):
        raise GraphSpecError(path, "must be a table of adverb = value", "adverbs")
    for k, x in defaults.items():
        _number(path, x, f"adverbs.{k}")
    start = verb_named(raw["start"], "start") if "start" in raw else 0
    try:
        return Graph.make(str(raw.get("name", path.stem)), verbs, transitions, defaults, start, loops, str(path), clamps)
    except GraphError as e:
        raise GraphSpecError(path, str(e), e.field) from None
