"""What fuzzing found (issue 14), each as a test: arguments that used to hang, exhaust memory, write what the
reader refuses or raise something other than the project's error — refused at once, in one line, naming what
was asked and the limit; and the API validating its arguments at the boundary."""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import BANDAI, CMU
from test_cli import run

from adverbs import AdverbsError, read_bvh
from adverbs.errors import AdverbsWarning
from adverbs.kinematics.floor import parse_floor
from adverbs.limits import LIMITS, LimitError, check_frames
from adverbs.feet.offline import plant_feet

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def walk_file(verbs, tmp_path_factory):
    from adverbs.verb.store import save_verb

    path = tmp_path_factory.mktemp("refusals") / "walk.verb"
    save_verb(verbs["cmu_walk"][0], path)
    return path


def _cli(*args) -> tuple[subprocess.CompletedProcess, float]:
    """The command in a child process with its address space capped (a blow-up fails instead of swapping)."""
    started = time.perf_counter()
    r = run(*args, limits={resource.RLIMIT_AS: 3 << 30}, timeout=120)
    return r, time.perf_counter() - started


@pytest.mark.parametrize(
    "args, said",
    [
        (("--adverb", "speed=100", "--duration", "1", "--fps", "2"), "the motion degenerates there"),  # looped forever
        (("--adverb", "speed=50", "--duration", "10"), "the motion degenerates there"),  # MemoryError at 3.8 GB
        (("--fps", "1e-6", "--duration", "3e7"), "fps 1e-06 is too low: one cycle"),  # MemoryError with 31 frames
        (("--adverb", "turn=-1e4",), "one cycle would last"),  # ran past 120 s
        (("--duration", "35000"), "is 1,050,001 frames; the limit is 200,000 per clip"),  # ~940,000 exhausted memory
        (("--floor", "flat:1e308"), "floor level must be a height in metres from -10000 to 10000"),  # wrote garbage
        (("--floor", "slope:90"), "slope must be between -80 and 80 degrees, got 90"),  # said "'90' is not a number"
    ],
)  # fmt: skip
def test_synth_refuses_at_once_in_one_line(walk_file, tmp_path, args, said):
    out = tmp_path / "x.bvh"
    r, seconds = _cli("synth", walk_file, *args, "-o", out)
    assert r.returncode == 1 and said in r.stderr, r.stderr
    errors = [line for line in r.stderr.splitlines() if not line.startswith("adverbs: warning: ")]
    assert len(errors) == 1 and errors[0].startswith("adverbs: error: "), r.stderr  # no traceback, no NumPy notes
    assert not out.exists()
    assert seconds < 60  # a guard against a hang, not a timing target


@pytest.mark.parametrize(
    "fps, said",
    [("1e9", "fps must be a number from 0.0001 to 1e+06"), ("1e-5", "fps must be a number from 0.0001 to 1e+06"),
     ("2e5", "frames; the limit is 200,000 per clip")],
)  # fmt: skip
def test_convert_refuses_frame_rates_it_cannot_hold_or_afford(tmp_path, fps, said):
    # 1e9 asked for 31 GiB; 1e-5 wrote a Frame Time the reader refuses, with exit status 0
    out = tmp_path / "x.bvh"
    r, _ = _cli("convert", CMU / "16_15_walk.bvh", out, "--fps", fps)
    assert r.returncode == 1 and said in r.stderr and "Traceback" not in r.stderr, r.stderr
    assert not out.exists()


def test_limits_say_what_was_asked_and_can_be_raised(monkeypatch):
    with pytest.raises(LimitError, match=r"10 s at 1e\+06 fps is 10,000,000 frames; the limit is 200,000 per clip \(ADVERBS_MAX_FRAMES"):
        check_frames(1e7, 31, "10 s at 1e+06 fps")
    with pytest.raises(LimitError, match=r"150,000 frames of 10000 joints, about 559 GiB of memory; the limit is 4 GiB"):
        check_frames(150_000, 10_000, "x")
    with pytest.raises(LimitError, match="not a number of frames"):
        check_frames(float("nan"), 31, "x")
    assert check_frames(150_000.0, 31, "x") == 150_000
    monkeypatch.setattr(LIMITS, "frames", 10)
    with pytest.raises(LimitError, match="the limit is 10 per clip"):
        check_frames(11, 1, "x")
    # and from the environment, in a fresh process
    r = subprocess.run(
        [sys.executable, "-c", "from adverbs.limits import LIMITS; print(LIMITS.frames, LIMITS.memory, LIMITS.joints)"],
        capture_output=True, text=True, env={"ADVERBS_MAX_FRAMES": "5000", "ADVERBS_MAX_MEMORY": "1.5G", "ADVERBS_MAX_JOINTS": "7", "PATH": ""},
    )  # fmt: skip
    assert r.stdout.split() == ["5000", str(int(1.5 * (1 << 30))), "7"], r.stderr
    # a malformed variable: the package still imports, and the first checked work (every command) says so in one line
    env = {**os.environ, "ADVERBS_MAX_FRAMES": "abc"}
    code = "import adverbs, sys; from adverbs.apps.cli import main; sys.exit(main(['info', sys.argv[1]]))"
    r = subprocess.run([sys.executable, "-c", code, str(CMU / "16_15_walk.bvh")], capture_output=True, text=True, env=env)
    assert r.returncode == 1 and r.stderr.strip() == (
        "adverbs: error: ADVERBS_MAX_FRAMES='abc': give a whole number, optionally with K, M, G or T (e.g. 4G)"
    ), r.stderr


@pytest.mark.parametrize(
    "var, value, shown",
    [("ADVERBS_MAX_FRAMES", "9" * 400, "'99999999999999999999'… (400 characters)"),
     ("ADVERBS_MAX_MEMORY", "9" * 5000 + "T", "'99999999999999999999'… (5001 characters)"),  # past int()'s 4300 digits
     ("ADVERBS_MAX_JOINTS", str(1 << 70), "'1180591620717411303424'")],
)  # fmt: skip
def test_a_limit_of_hundreds_of_digits_is_refused_in_one_line(var, value, shown):
    """400 nines were an OverflowError at ``import adverbs`` (a float's infinity made an int), on every command."""
    env = {**os.environ, var: value}
    code = (
        "import sys; from adverbs.limits import LIMITS, Limits; assert LIMITS == Limits(), LIMITS; "
        "from adverbs.apps.cli import main; sys.exit(main(['info', sys.argv[1]]))"
    )
    r = subprocess.run([sys.executable, "-c", code, CMU / "16_15_walk.bvh"], capture_output=True, text=True, env=env)
    assert r.returncode == 1 and r.stdout == "", r.stderr  # the defaults kept, and the command refused
    assert r.stderr.splitlines() == [
        f"adverbs: error: {var}={shown}: more than 4,611,686,018,427,387,904; give a whole number up to that"
    ]


def test_the_api_refuses_bad_arguments_with_its_own_error(verbs):
    verb, _ = verbs["cmu_walk"]
    mean = verb.points.mean(axis=0)
    with pytest.raises(AdverbsError, match="degenerates"):  # a cycle of 1.3 µs: was ZeroDivisionError, then refused
        verb.pose(mean + [50.0, 1e4], 0.5)  # by synthesize only
    assert np.all(np.isfinite(verb.pose(mean + [0.5, 50.0], 0.5)))  # extrapolated, not degenerate
    for bad, said in ((np.array([]), "takes 2 adverbs"), ("fast", "an adverb point is 2 numbers"),
                      ([np.nan, 0.0], "must be a finite number"), ({"sped": 1.0}, "has no adverb 'sped'")):  # fmt: skip
        with pytest.raises(AdverbsError, match=said):
            verb.synthesize(bad)
    with pytest.raises(AdverbsError, match="takes 2 adverbs"):
        verb.pose(np.array([]), 0.5)  # a fresh verb: was IndexError
    clip, k = verb.synthesize(mean[None])  # a (1, A) point: was NumPy's "truth value ... ambiguous"
    assert clip.num_frames > 2
    # plant_feet: a clip of another skeleton, keytimes negative (hung), out of order, NaN, the wrong number
    bow = read_bvh(BANDAI / "dataset-1_bow_normal_001.bvh")
    with pytest.raises(AdverbsError, match="is not on the skeleton of verb 'cmu-walk': it has 22 joints, not 19"):
        plant_feet(verb, bow, k, None, mean)
    for keytimes, said in ((k - 5.0, "from 0"), (k[::-1], "strictly increasing"), (k * np.nan, "finite"),
                           (k[:-1], r"must be \d+ times")):  # fmt: skip
        with pytest.raises(AdverbsError, match=said):
            plant_feet(verb, clip, keytimes, None, mean)


def test_floors_refuse_what_they_cannot_be():
    for text, said in (("flat:1e308", "from -10000 to 10000"), ("flat:nan", "from -10000 to 10000"),
                       ("slope:90", "between -80 and 80 degrees, got 90"), ("slope:x", "'x' is not a number"),
                       ("slope:", "'' is not a number")):  # fmt: skip
        with pytest.raises(AdverbsError, match=said):
            parse_floor(text)
    assert parse_floor("flat").level == 0.0 and parse_floor("flat:9999").level == 9999.0


def test_a_recorded_run_past_the_limit_is_refused_before_it_runs(monkeypatch):
    from adverbs import Simulation, load_graph

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        graph = load_graph(ROOT / "graphs" / "cmu.toml")
    sim = Simulation(graph, fps=30)
    sim.add_creature()
    monkeypatch.setattr(LIMITS, "frames", 100)
    with pytest.raises(LimitError, match=r"recording 4 s at 30 fps is 120 frames; the limit is 100"):
        sim.run(4.0)
    assert sim.frames == 0
    sim.run(3.0)  # within it: runs
    assert sim.frames == 90


def test_resampling_checks_its_budget():
    clip = read_bvh(CMU / "16_15_walk.bvh")
    with pytest.raises(LimitError, match="frames"):
        clip.resample(1e5)
    with pytest.raises(AdverbsError, match="1-D array of finite numbers"):
        clip.at(np.array([0.0, np.nan]))
