"""Hostile verb specs: every value of the wrong type, out of range, not finite or absurdly large, and TOML built to
exhaust the reader, is a SpecError naming the file and the field, never another exception or a hang (issue 14)."""

from __future__ import annotations

import json
import math
import time
import tomllib
from pathlib import Path

import pytest
from conftest import SPECS
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from adverbs.errors import AdverbsError
from adverbs.limits import LIMITS
from adverbs.verb import spec as spec_module
from adverbs.verb.spec import MAX_KEY_DOTS, MAX_TOML_BYTES, SpecError, load_spec

GOOD = """
name = "walk"
num_cp = 12
cut = { foot = "left", steps = 2 }

[[adverbs]]
name = "turn"
measure = "turn_rate"

[[adverbs]]
name = "mood"
measure = { kind = "joint_position", joint = "Head", axis = "y", keytime = 1 }

[[examples]]
name = "a"
file = "a.bvh"
adverbs = { mood = 0.0 }

[[examples]]
name = "b"
file = "b.bvh"
frames = [0, 40]
keytimes = [0.0, 0.5, 1.3]
adverbs = { mood = 1.0 }
"""


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "walk.toml"
    path.write_text(text)
    return path


def fails(path: Path, field: str | None, *words: str, example: str | None = None) -> SpecError:
    with pytest.raises(SpecError) as info:
        load_spec(path)
    err = info.value
    assert err.field == field and err.example == example, str(err)
    assert str(path) in str(err)
    for w in words:
        assert w in err.reason, err.reason
    return err


def test_the_good_spec_loads(tmp_path):
    spec = load_spec(write(tmp_path, GOOD))
    assert spec["num_cp"] == 12 and len(spec["examples"]) == 2


def test_every_shipped_spec_loads():
    for path in sorted(SPECS.glob("*.toml")):
        assert load_spec(path)["examples"]


# ----- booleans are not numbers ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "old, new, field, example",
    [
        ("steps = 2 }", "steps = 2, strike = true }", "cut.strike", None),
        ("steps = 2 }", "steps = true }", "cut.steps", None),
        ("num_cp = 12", "num_cp = true", "num_cp", None),
        ('file = "a.bvh"', 'file = "a.bvh"\ncut = { strike = false }', "cut.strike", "a"),
        ("frames = [0, 40]", "frames = [true, 40]", "frames", "b"),
        ("keytimes = [0.0, 0.5, 1.3]", "keytimes = [0.0, true, 1.3]", "keytimes", "b"),
        ("adverbs = { mood = 1.0 }", "adverbs = { mood = true }", "adverbs.mood", "b"),
        ("keytime = 1 }", "keytime = true }", "adverbs.mood.measure", None),
        ("num_cp = 12", "num_cp = 12\nfps = true", "fps", None),
        ("num_cp = 12", "num_cp = 12\nfloor = false", "floor", None),
        ("num_cp = 12", "num_cp = 12\nsmoothing = true", "smoothing", None),
    ],
)
def test_booleans_do_not_pass_as_numbers(tmp_path, old, new, field, example):
    assert old in GOOD
    fails(write(tmp_path, GOOD.replace(old, new, 1)), field, "true" if "true" in new else "false", example=example)


# ----- absurd, negative and non-finite numbers ------------------------------------------------------------------


def test_num_cp_is_bounded_by_the_frame_limit(tmp_path):
    for value in (10**12, 2**63 - 1, LIMITS.frames + 1):
        start = time.perf_counter()
        fails(write(tmp_path, GOOD.replace("num_cp = 12", f"num_cp = {value}")), "num_cp", f"{LIMITS.frames:,}")
        assert time.perf_counter() - start < 1.0
    for value in (-5, 3, 0):
        fails(write(tmp_path, GOOD.replace("num_cp = 12", f"num_cp = {value}")), "num_cp", "from 4")
    assert (
        load_spec(write(tmp_path, GOOD.replace("num_cp = 12", f"num_cp = {LIMITS.frames}")))["num_cp"] == LIMITS.frames
    )


@pytest.mark.parametrize(
    "old, new, field, example",
    [
        ("steps = 2 }", "steps = 2, strike = -1 }", "cut.strike", None),
        ("steps = 2 }", "steps = 2, strike = 1_000_000_000_000 }", "cut.strike", None),
        ("steps = 2 }", "steps = 0 }", "cut.steps", None),
        ("steps = 2 }", "steps = 9223372036854775807 }", "cut.steps", None),
        ("steps = 2 }", "steps = 2.5 }", "cut.steps", None),
        ("frames = [0, 40]", "frames = [0, 99999999999]", "frames", "b"),
        ("frames = [0, 40]", "frames = [0, 40.0]", "frames", "b"),
        ("frames = [0, 40]", "frames = [0]", "frames", "b"),
        ("keytimes = [0.0, 0.5, 1.3]", "keytimes = [0.0, nan, 1.3]", "keytimes", "b"),
        ("keytimes = [0.0, 0.5, 1.3]", "keytimes = [0.0, inf, 1.3]", "keytimes", "b"),
        ("adverbs = { mood = 1.0 }", "adverbs = { mood = -inf }", "adverbs.mood", "b"),
        ("adverbs = { mood = 1.0 }", "adverbs = { mood = 1e308 }", "adverbs.mood", "b"),  # a typo, not a mood
        ("keytime = 1 }", "keytime = -1 }", "adverbs.mood.measure", None),
        ("keytime = 1 }", "keytime = 10000000000000 }", "adverbs.mood.measure", None),
        ("num_cp = 12", "num_cp = 12\nfps = nan", "fps", None),
        ("num_cp = 12", "num_cp = 12\nfps = -30", "fps", None),
        ("num_cp = 12", "num_cp = 12\nfps = 1e300", "fps", None),
        ("num_cp = 12", "num_cp = 12\nfloor = inf", "floor", None),
        ("num_cp = 12", "num_cp = 12\nshrinkage = -1", "shrinkage", None),
        ("num_cp = 12", "num_cp = 12\nsmoothing = nan", "smoothing", None),
        (
            "num_cp = 12",
            'num_cp = 12\nconstraints = [{ effector = "ltoes", open = -1, close = 1 }]',
            "constraints",
            None,
        ),
        (
            "num_cp = 12",
            'num_cp = 12\nconstraints = [{ effector = "ltoes", open = 0, close = 1e3 }]',
            "constraints",
            None,
        ),
        ("num_cp = 12", "num_cp = 12\nconstraints = [{ effector = 5, open = 0, close = 1 }]", "constraints", None),
    ],
)
def test_numbers_out_of_range_are_refused_naming_the_field(tmp_path, old, new, field, example):
    assert old in GOOD
    fails(write(tmp_path, GOOD.replace(old, new, 1)), field, example=example)


# ----- values of the wrong type ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "old, new, field, example",
    [
        ('name = "walk"', "name = { a = 1 }", "name", None),
        ('cut = { foot = "left", steps = 2 }', 'cut = "left"', "cut", None),
        ('cut = { foot = "left", steps = 2 }', "cut = { foot = 0, steps = 2 }", "cut.foot", None),
        ('cut = { foot = "left", steps = 2 }', "cut = { foot = true, steps = 2 }", "cut.foot", None),
        ('cut = { foot = "left", steps = 2 }', 'cut = { foot = "middle" }', "cut.foot", None),
        ('cut = { foot = "left", steps = 2 }', 'cut = { events = ["strikes"] }', "cut.events", None),
        ('cut = { foot = "left", steps = 2 }', "cut = { stride = 2 }", "cut.stride", None),
        ('measure = "turn_rate"', "measure = 5", "adverbs.turn.measure", None),
        ('measure = "turn_rate"', 'measure = ["turn_rate"]', "adverbs.turn.measure", None),
        ('measure = "turn_rate"', "measure = { kind = { a = 1 } }", "adverbs.turn.measure", None),
        ('joint = "Head"', "joint = 3", "adverbs.mood.measure", None),
        ('axis = "y"', "axis = [1]", "adverbs.mood.measure", None),
        ('name = "turn"', 'name = "turn"\nunit = { a = 1 }', "adverbs.turn.unit", None),
        ('file = "a.bvh"', "file = [1, 2]", "file", "a"),
        ('file = "a.bvh"', 'file = "a.bvh"\ncut = 5', "cut", "a"),
        ('file = "a.bvh"', 'file = "a.bvh"\nmirror = "yes"', "mirror", "a"),
        ('file = "a.bvh"', 'file = "a.bvh"\nrefine = 1', "refine", "a"),
        ('file = "a.bvh"', 'file = "a.bvh"\ndescription = 1.5', "description", "a"),
        ("keytimes = [0.0, 0.5, 1.3]", 'keytimes = "0 0.5 1.3"', "keytimes", "b"),
        ("keytimes = [0.0, 0.5, 1.3]", "keytimes = { peak = 5 }", "keytimes", "b"),
        ("keytimes = [0.0, 0.5, 1.3]", 'keytimes = { peak = "Head", low = "Foot" }', "keytimes", "b"),
        ("adverbs = { mood = 1.0 }", 'adverbs = "happy"', "adverbs", "b"),
        ("adverbs = { mood = 1.0 }", 'adverbs = { mood = "1.0" }', "adverbs.mood", "b"),
        ("adverbs = { mood = 1.0 }", "adverbs = { mood = [1.0] }", "adverbs.mood", "b"),
        ("num_cp = 12", 'num_cp = "12"', "num_cp", None),
        ("num_cp = 12", "num_cp = 12.0", "num_cp", None),
        ("num_cp = 12", "num_cp = 12\nencoding = [1]", "encoding", None),
        ("num_cp = 12", "num_cp = 12\nkeytime_spacing = { a = 1 }", "keytime_spacing", None),
        ("num_cp = 12", 'num_cp = 12\nconstraints = "none"', "constraints", None),
        ("num_cp = 12", "num_cp = 12\nconstraints = [1]", "constraints[0]", None),
        ("num_cp = 12", 'num_cp = 12\nskeleton = ["a.bvh"]', "skeleton", None),
    ],
)
def test_values_of_the_wrong_type_are_refused_naming_the_field(tmp_path, old, new, field, example):
    assert old in GOOD
    fails(write(tmp_path, GOOD.replace(old, new, 1)), field, example=example)


def test_example_name_of_the_wrong_type(tmp_path):
    fails(write(tmp_path, GOOD.replace('name = "a"', "name = 7")), "name", "must be a string", example="#1")


# ----- TOML built to exhaust the reader -------------------------------------------------------------------------


def _quick(path: Path, *words: str) -> SpecError:
    start = time.perf_counter()
    with pytest.raises(SpecError) as info:
        load_spec(path)
    assert time.perf_counter() - start < 2.0
    assert str(path) in str(info.value)
    for w in words:
        assert w in info.value.reason, info.value.reason
    return info.value


def test_deep_nesting_and_huge_integers(tmp_path):
    _quick(write(tmp_path, GOOD + "\nx = " + "[" * 5000 + "]" * 5000 + "\n"), "nested too deeply")
    _quick(write(tmp_path, GOOD + "\nx = " + "{ a = " * 3000 + "1" + " }" * 3000 + "\n"), "nested too deeply")
    _quick(write(tmp_path, GOOD.replace("num_cp = 12", "num_cp = " + "9" * 5000)), "not valid TOML", "digits")


def test_long_dotted_keys_are_refused_before_they_are_parsed(tmp_path):
    # Python's TOML reader takes time quadratic in a dotted key's length: 100,000 parts would run for minutes.
    path = write(tmp_path, GOOD + "\n" + "a." * 100_000 + "b = 1\n")
    _quick(path, f"line {GOOD.count(chr(10)) + 2}", "keys with 100000 dots")
    _quick(write(tmp_path, GOOD + '\n"a"' + ' . "a"' * 100_000 + " = 1\n"), "100000 dots")
    _quick(write(tmp_path, GOOD + "\n[" + "a." * 50_000 + "b]\n"), "50000 dots")
    # an escaped quote does not hide the key from the scan
    _quick(write(tmp_path, GOOD + '\n"\\"".' + "a." * 1000 + 'b = ""\n'), "1001 dots")
    # in an array of tables after a multi-line string that ends in extra quotes
    _quick(write(tmp_path, 'x = ["""a""""' + ", {" + "a." * 100 + "b = 1}]\n"), "100 dots")


def test_dots_in_strings_comments_and_numbers_are_not_keys(tmp_path):
    many = "." * (10 * MAX_KEY_DOTS)
    extra = (
        f'\n# a comment {many}\ndescription = "{many}"\nx = \'{many}\'\ny = """\n{many}\n{many}"""\n'
        f"z = '''{many}'''\nv = [{', '.join(['1.5'] * 50)}, 1979-05-27T07:32:00.999]\nw = {{ a.b = \"{many}\" }}\n"
    )
    text = GOOD.replace('name = "walk"', 'name = "walk"' + extra)
    tomllib.loads(text)  # valid TOML
    fails(write(tmp_path, text), "v")  # loads up to the unknown field: not refused for its dots
    assert spec_module._most_key_dots(text)[1] <= 2


def test_a_file_too_big_or_endless_is_not_read(tmp_path):
    big = write(tmp_path, GOOD + "# " + "x" * MAX_TOML_BYTES + "\n")
    _quick(big, "over 1024 KiB")
    if Path("/dev/zero").exists():
        _quick(Path("/dev/zero"), "over 1024 KiB")


# ----- fuzzing the shipped specs --------------------------------------------------------------------------------

SHIPPED = {p.name: tomllib.loads(p.read_text()) for p in sorted(SPECS.glob("*.toml"))}


def toml_value(v) -> str:
    """``v`` as a TOML value, inline (tables and arrays of tables too)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    return "{ " + ", ".join(f"{json.dumps(k, ensure_ascii=False)} = {toml_value(x)}" for k, x in v.items()) + " }"


def toml_document(table: dict) -> str:
    return "".join(f"{json.dumps(k, ensure_ascii=False)} = {toml_value(v)}\n" for k, v in table.items())


values = st.one_of(
    st.booleans(),
    st.integers(),
    st.sampled_from([0, -1, 1, 4, 2**63 - 1, -(2**63), 10**12, LIMITS.frames + 1]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=8),
    st.sampled_from(["left", "right", "most_turning", "auto", "even", "contacts", "logquat", "turn_rate", "x"]),
    st.lists(st.one_of(st.integers(-5, 50), st.floats(), st.booleans(), st.text(max_size=3)), max_size=4),
    st.dictionaries(
        st.sampled_from(["kind", "foot", "peak", "mood", "a", "joint"]),
        st.integers(-3, 3) | st.text(max_size=3),
        max_size=3,
    ),
)


def _paths(node, prefix=()):
    """Every (path, value) inside ``node``, tables and arrays alike."""
    yield prefix, node
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _paths(v, prefix + (i,))


@st.composite
def mutated(draw):
    name = draw(st.sampled_from(sorted(SHIPPED)))
    doc = json.loads(json.dumps(SHIPPED[name]))  # a deep copy
    for _ in range(draw(st.integers(1, 3))):
        places = [p for p, _ in _paths(doc) if p]
        path = draw(st.sampled_from(places))
        parent = doc
        for k in path[:-1]:
            parent = parent[k]
        key = path[-1]
        action = draw(st.sampled_from(["replace", "replace", "replace", "delete", "huge"]))
        if action == "delete":
            del parent[key]
        elif action == "huge":
            parent[key] = draw(st.sampled_from([10**18, -(10**18), 2**63 - 1, 1e308, -1e308, -7, 10**9]))
        else:
            parent[key] = draw(values)
    event(f"mutated {name}")
    return toml_document(doc)


@settings(
    derandomize=True, database=None, deadline=None, max_examples=250, suppress_health_check=[HealthCheck.too_slow]
)
@given(text=mutated())
def test_mutated_specs_load_or_are_refused_with_a_spec_error(text, tmp_path_factory):
    path = tmp_path_factory.mktemp("spec") / "fuzz.toml"
    path.write_text(text)
    start = time.perf_counter()
    try:
        spec = load_spec(path)
    except AdverbsError as e:
        assert str(path) in str(e)
        event(f"refused: {type(e).__name__}")
    else:
        event("loaded")
        assert isinstance(spec["num_cp"], int) and not isinstance(spec["num_cp"], bool)
        assert 4 <= spec["num_cp"] <= LIMITS.frames
        for ex in spec["examples"]:
            assert isinstance(ex["name"], str) and isinstance(ex["file"], str)
    assert time.perf_counter() - start < 2.0
