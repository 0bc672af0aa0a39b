"""Hostile graph specs (issue 33): the shipped graphs with their fields replaced. Each loads into a graph whose
likelihoods, chances and adverb defaults are finite, or is refused with one GraphSpecError (an AdverbsError)
naming the file and the field; never another exception or a hang. ``loop_likelihood = inf`` loaded and described
its loop's chance as NaN."""

from __future__ import annotations

import json
import math
import tomllib
import warnings
from datetime import timedelta
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from hostile import bounded, draw_field
from test_cli import run
from test_spec_safety import toml_document

from adverbs.errors import AdverbsError, AdverbsWarning
from adverbs.graph import load_graph
from adverbs.graph.spec import MAX_LIKELIHOOD, GraphSpecError
from adverbs.verb.store import save_verb

ROOT = Path(__file__).resolve().parent.parent
FUZZ = settings(
    derandomize=True, database=None, deadline=timedelta(seconds=5), max_examples=100,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)  # fmt: skip


@pytest.fixture(scope="module")
def shipped(tmp_path_factory) -> dict[str, dict]:
    """The shipped graphs as TOML tables, their verbs built once and given as verb files (no renames left to do)."""
    out = tmp_path_factory.mktemp("graphs")
    docs = {}
    for name in ("cmu", "bandai"):
        path = ROOT / "graphs" / f"{name}.toml"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", AdverbsWarning)
            graph = load_graph(path)
        doc = tomllib.loads(path.read_text())
        for entry, verb in zip(doc["verbs"], graph.verbs):
            save_verb(verb, out / f"{name}_{entry['name']}.verb")
            del entry["spec"]
            entry.pop("adverbs", None)  # the saved verb's adverbs carry the graph's names already
            entry["verb"] = str(out / f"{name}_{entry['name']}.verb")
        docs[name] = doc
    return docs


def load(path: Path):
    with warnings.catch_warnings(), bounded():
        warnings.simplefilter("ignore", AdverbsWarning)
        return load_graph(path)


def check_loaded(graph) -> None:
    """What a loaded graph must hold: finite positive likelihoods up to the bound, chances that are numbers summing
    to 1 out of every verb, finite defaults, draws that work, and a description JSON takes without NaN."""
    for t in graph.transitions:
        assert 0 < t.likelihood <= MAX_LIKELIHOOD, t
    for v in range(len(graph.verbs)):
        ways = graph.leaving(v)
        p = np.array([graph.transitions[k].likelihood for k in ways])
        assert np.all(np.isfinite(p / p.sum())) and abs((p / p.sum()).sum() - 1.0) < 1e-12
        assert graph.draw(v, np.random.default_rng(0)) in ways
    assert np.all(np.isfinite(graph.defaults))
    json.dumps(graph.describe(), allow_nan=False)


def test_the_shipped_graphs_load_from_their_built_verbs(shipped, tmp_path):
    for name, doc in shipped.items():
        path = tmp_path / f"{name}.toml"
        path.write_text(toml_document(doc))
        check_loaded(load(path))


BAD_LIKELIHOODS = [math.inf, -math.inf, math.nan, 1e308, 2e6, 0, -1, "3", True]


@pytest.mark.parametrize("value", BAD_LIKELIHOODS)
@pytest.mark.parametrize(
    "graph, table, key, field",
    [("cmu", "verbs", "loop_likelihood", "verbs[2].loop_likelihood"),
     ("bandai", "transitions", "likelihood", "transitions[2].likelihood")],
)  # fmt: skip
def test_a_likelihood_that_is_not_a_weight_is_refused_naming_it(shipped, tmp_path, graph, table, key, field, value):
    doc = json.loads(json.dumps(shipped[graph]))
    doc[table][1][key] = value
    path = tmp_path / "g.toml"
    path.write_text(toml_document(doc))
    with pytest.raises(GraphSpecError) as info:
        load(path)
    assert info.value.field == field and info.value.path == str(path), str(info.value)
    assert str(info.value).startswith(f"{path}: field '{field}': ") and "number" in str(info.value)


def test_likelihoods_at_the_bounds_load_with_finite_chances(shipped, tmp_path):
    doc = json.loads(json.dumps(shipped["bandai"]))
    doc["verbs"][1]["loop_likelihood"] = MAX_LIKELIHOOD
    for t in doc["transitions"]:
        t["likelihood"] = MAX_LIKELIHOOD
    doc["transitions"][0]["likelihood"] = 1e-300
    path = tmp_path / "g.toml"
    path.write_text(toml_document(doc))
    graph = load(path)
    check_loaded(graph)
    loop = next(t for t in graph.transitions if t.source == t.target == 1)
    assert loop.likelihood == MAX_LIKELIHOOD


def test_the_command_line_refuses_an_infinite_loop_likelihood_in_one_line(shipped, tmp_path):
    doc = json.loads(json.dumps(shipped["cmu"]))
    doc["verbs"][0]["loop_likelihood"] = math.inf
    path = tmp_path / "g.toml"
    path.write_text(toml_document(doc))
    r = run("graph", path, "--describe", timeout=60)
    assert r.returncode == 1 and "chance nan" not in r.stdout, r.stdout
    lines = r.stderr.splitlines()  # "loading graph ...", each verb read, then the one error
    assert "Traceback" not in r.stderr and sum(x.startswith("adverbs: error:") for x in lines) == 1, r.stderr
    assert lines[-1] == (
        f"adverbs: error: {path}: field 'verbs[1].loop_likelihood': must be a positive number up to 1e+06 "
        "(a weight among the ways out of a verb), got inf"
    )


# ----- fuzzing the shipped graphs -------------------------------------------------------------------------------

VALUES = st.one_of(
    st.booleans(),
    st.integers(-3, 10),
    st.sampled_from([10**18, -(10**18), 2**63 - 1, 10**6, 10**7]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([1e308, -1e308, 1e-308, 5e-324, 1e6, 1e6 + 1, 0.5, 1.0]),
    st.text(max_size=6),
    st.sampled_from(["walk", "run", "idle", "bow", "cosine", "inertial", "turn", "/dev/zero", "../x.verb"]),
    st.lists(st.one_of(st.floats(allow_nan=True), st.integers(-2, 2), st.text(max_size=2)), max_size=3),
    st.dictionaries(st.sampled_from(["turn", "valence", "speed", "x"]), st.floats() | st.text(max_size=2), max_size=2),
)


@st.composite
def mutated(draw, shipped) -> str:
    """A shipped graph with 1-3 of its fields (the likelihoods, regions, names, defaults, anything) replaced by a
    hostile value or deleted, or a likelihood field added where it had none."""
    name = draw(st.sampled_from(sorted(shipped)))
    doc = json.loads(json.dumps(shipped[name]))
    for _ in range(draw(st.integers(1, 3))):
        action = draw(st.sampled_from(["replace", "replace", "delete", "likelihood"]))
        if action == "likelihood":
            table = draw(st.sampled_from([("verbs", "loop_likelihood"), ("transitions", "likelihood")]))
            entry = draw(st.sampled_from(doc[table[0]])) if doc.get(table[0]) else None
            if isinstance(entry, dict):
                entry[table[1]] = draw(VALUES)
            continue
        parent, key, path = draw_field(draw, st, doc, keep=lambda p: p[-1] != "verb")  # the verb files stay
        if action == "delete":
            del parent[key]
        else:
            parent[key] = draw(VALUES)
        event(f"{action} {path[0]}")
    return toml_document(doc)


def test_mutated_graphs_load_finite_or_are_refused_naming_the_field(shipped, tmp_path):
    path = tmp_path / "fuzz.toml"

    @FUZZ
    @given(text=mutated(shipped))
    def check(text):
        path.write_text(text)
        try:
            graph = load(path)
        except AdverbsError as e:
            assert str(path) in str(e) and "\n" not in str(e), str(e)
            event(f"refused: {type(e).__name__}")
        else:
            check_loaded(graph)
            event("loaded")

    check()
