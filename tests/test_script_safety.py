"""Hostile runtime scripts (issue 33): the demo script with its fields replaced loads into a script whose creatures
stand within 10 km of the origin facing a finite heading, and plays a moment with every pose finite; or it is
refused with one AdverbsError naming the file and the field, as it loads or as it is applied to the simulation.
A creature at ``[1e308, 0]`` used to load, run the whole scene and fail only when the writer met infinity."""

from __future__ import annotations

import json
import math
import time
import tomllib
import warnings
from datetime import timedelta
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from hostile import bounded, draw_field
from test_spec_safety import toml_document

from adverbs import Simulation, load_graph
from adverbs.errors import AdverbsError, AdverbsWarning
from adverbs.runtime.script import PLACE_LIMIT, ScriptError, load_script
from adverbs.verb.spec import MAX_TOML_BYTES

ROOT = Path(__file__).resolve().parent.parent
DEMO = ROOT / "scripts" / "demo.toml"
FUZZ = settings(
    derandomize=True, database=None, deadline=timedelta(seconds=5), max_examples=100,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)  # fmt: skip
ONE = """seconds = 2

[[creatures]]
name = "a"
graph = "cmu"
at = {at}
heading = {heading}
"""


@pytest.fixture(scope="module")
def graphs():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        return [load_graph(ROOT / "graphs" / "bandai.toml"), load_graph(ROOT / "graphs" / "cmu.toml")]


def refused(path: Path, line: int, field: str, *words: str) -> ScriptError:
    with bounded(), pytest.raises(ScriptError) as info:
        load_script(path)
    err = info.value
    assert (err.line, err.field) == (line, field), str(err)
    where = f"{path}, line {line}" if line else str(path)
    assert str(err).startswith(f"{where}: {field}: " if field else f"{where}: ") and "\n" not in str(err), str(err)
    for w in words:
        assert w in str(err), str(err)
    return err


@pytest.mark.parametrize(
    "at, heading, field, words",
    [
        ("[1e308, 0.0]", "0", "creatures[0].at[0]", ("from -10000 to 10000 metres", "got 1e+308")),
        ("[0.0, -10000.5]", "0", "creatures[0].at[1]", ("from -10000 to 10000 metres",)),
        ("[inf, 0.0]", "0", "creatures[0].at[0]", ("got inf",)),
        ("[nan, 0.0]", "0", "creatures[0].at[0]", ("got nan",)),
        ("[0.0, 0.0]", "1e300", "creatures[0].heading", ("from -360 to 360 degrees", "got 1e+300")),
        ("[0.0, 0.0]", "-inf", "creatures[0].heading", ("from -360 to 360 degrees",)),
        ("[0.0, 0.0]", "true", "creatures[0].heading", ("got True",)),
    ],
)
def test_a_creature_placed_past_the_floor_or_turned_past_a_turn_is_refused_at_load(tmp_path, at, heading, field, words):
    path = tmp_path / "s.toml"
    path.write_text(ONE.format(at=at, heading=heading))
    line = 6 if field.startswith("creatures[0].at") else 7
    refused(path, line, field, *words)


def test_a_creature_at_the_bound_plays_with_finite_poses(tmp_path, graphs):
    path = tmp_path / "s.toml"
    path.write_text(ONE.format(at=f"[{PLACE_LIMIT}, {-PLACE_LIMIT}]", heading="-360"))
    script = load_script(path)
    assert script.creatures[0].at == (PLACE_LIMIT, -PLACE_LIMIT)
    sim = Simulation(graphs, fps=30)
    script.apply(sim)
    sim.run(1.0)
    positions = sim.creatures[0].clip().global_positions()
    assert np.all(np.isfinite(positions))
    assert np.abs(positions[..., 0] - PLACE_LIMIT).max() < 5.0 and np.abs(positions[..., 2] + PLACE_LIMIT).max() < 5.0


def test_a_script_too_big_or_endless_is_not_read(tmp_path):
    big = tmp_path / "big.toml"
    big.write_text("seconds = 2\n# " + "x" * MAX_TOML_BYTES + "\n")  # read whole, with no cap, before
    started = time.perf_counter()
    refused(big, 0, "", "over 1024 KiB", "script")
    if Path("/dev/zero").exists():
        refused(Path("/dev/zero"), 0, "", "over 1024 KiB")
    assert time.perf_counter() - started < 5.0
    deep = tmp_path / "deep.toml"
    deep.write_text("seconds = " + "[" * 100_000 + "]" * 100_000 + "\n")
    refused(deep, 0, "", "nested too deeply")
    huge = tmp_path / "huge.toml"
    huge.write_text("seconds = 2\nseed = " + "9" * 5000 + "\n")
    refused(huge, 0, "", "not valid TOML", "digits")


def test_a_malformed_toml_line_is_still_named(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text("seconds = 2\n\n[[cues]]\nat = 1.0\nadverbs = { turn = }\n")
    refused(path, 5, "", "not valid TOML")


# ----- fuzzing the demo script ----------------------------------------------------------------------------------

VALUES = st.one_of(
    st.booleans(),
    st.integers(-5, 100),
    st.sampled_from([10**18, -(10**18), 2**63 - 1, 86_400, 86_401, 10_000, 10_001, -10_001]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([1e308, -1e308, 1e-308, 5e-324, 360.0, 360.5, -720.0, 9999.9]),
    st.text(max_size=6),
    st.sampled_from(["bandai", "cmu", "walk", "run", "idle", "fly", "a", "", "../graphs/cmu.toml"]),
    st.lists(st.one_of(st.floats(allow_nan=True), st.integers(-2, 2), st.text(max_size=2)), max_size=3),
    st.dictionaries(st.sampled_from(["turn", "valence", "walk_speed", "x"]), st.floats() | st.booleans(), max_size=2),
)
DOC = tomllib.loads(DEMO.read_text())


@st.composite
def mutated(draw) -> dict:
    """The demo script with 1-3 fields replaced by a hostile value or deleted, its run cut to a moment."""
    doc = json.loads(json.dumps(DOC))
    doc["graphs"] = []  # the test's simulation holds both graphs
    for _ in range(draw(st.integers(1, 3))):
        parent, key, path = draw_field(draw, st, doc)
        if draw(st.integers(0, 3)) == 0:
            del parent[key]
            event(f"delete {path[0]}")
        else:
            parent[key] = draw(VALUES)
            event(f"replace {path[0]}")
    return doc


def test_mutated_scripts_load_bounded_and_play_finite_or_are_refused_naming_the_field(tmp_path, graphs):
    path = tmp_path / "fuzz.toml"

    @FUZZ
    @given(doc=mutated())
    def check(doc):
        path.write_text(toml_document(doc))
        try:
            with bounded():
                script = load_script(path)
                for c in script.creatures:
                    assert all(math.isfinite(x) and abs(x) <= PLACE_LIMIT for x in c.at), c
                    assert math.isfinite(c.heading) and abs(c.heading) <= 360.0, c
                assert all(0.0 <= cue.at <= 86_400 and (cue.over is None or math.isfinite(cue.over)) for cue in script.cues)
                assert [cue.at for cue in script.cues] == sorted(cue.at for cue in script.cues)
                sim = Simulation(graphs, fps=30, seed=script.seed or 0)
                script.apply(sim)
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", AdverbsWarning)  # a cue refused when its time comes
                    sim.run(0.2)
        except AdverbsError as e:
            assert str(path) in str(e) and "\n" not in str(e), str(e)
            event(f"refused: {type(e).__name__}")
            return
        for c in sim.creatures:
            assert np.all(np.isfinite(c.clip().global_positions())), c.name
        event("played")

    check()
