"""Fits that hold between frames, at any frame rate, and cycles that keep their speed and turn when repeated.

* Synthesis at 120 fps (four times the capture's rate) at the examples, between them and 25% past
  them moves no joint faster than 1.5x the examples' own fastest (frame differences at their rate):
  on every shipped spec, and on the walks with toe-offs as keytimes, whose intervals are 0.5-2 frames.
* A 6-cycle synthesis at each example point travels and turns, in steady state, at the example's
  speed and turn rate within 3% of the examples' range, read from the root path alone (chords
  between cycle starts), not with the verb's own measures.
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
from conftest import RUN_SPECS, SPECS, VERB_SPECS

from adverbs import AdverbsError
from adverbs.errors import AdverbsWarning
from adverbs.interp import bspline, timewarp
from adverbs.verb.examples import examples_from_spec
from adverbs.verb import fit
from adverbs.verb.fit import build_verb, build_with_examples
from adverbs.verb.spec import SpecError, load_spec

TOE_OFF_SPECS = ["cmu_walk", "bandai_styled_walk"]  # the walks with toe-offs made keytimes too


def _largest_joint_speed(clip) -> float:
    return float(np.linalg.norm(np.diff(clip.global_positions(), axis=0), axis=-1).max() * clip.fps)


def _spread_points(verb):
    """The examples, the midpoint from each to its nearest neighbour, and 25% past each (from the centre)."""
    p = verb.points
    span = np.where(np.ptp(p, axis=0) > 0, np.ptp(p, axis=0), 1.0)
    q = p / span
    d = np.linalg.norm(q[:, None] - q[None], axis=-1)
    np.fill_diagonal(d, np.inf)
    c = p.mean(axis=0)
    return {"at examples": p, "between": 0.5 * (p + p[d.argmin(axis=1)]), "25% past": c + 1.25 * (p - c)}


def _toe_off_spec(tmp_path, name):
    """The shipped spec with toe-offs as keytimes too (``events = "contacts"``), written beside a copy of it."""
    text = (SPECS / f"{name}.toml").read_text()
    text = re.sub(r'^cut = \{', 'cut = { events = "contacts",', text, count=1, flags=re.M)
    text = text.replace('"../data/', f'"{SPECS.parent / "data"}/')
    path = tmp_path / f"{name}_toe_offs.toml"
    path.write_text(text)
    return path


def _build(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        return build_with_examples(path)


@pytest.fixture(scope="module")
def toe_off_verbs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("toe_offs")
    return {name: _build(_toe_off_spec(tmp, name)) for name in TOE_OFF_SPECS}


def _check_speeds(verb, examples):
    own = max(_largest_joint_speed(ex.clip) for ex in examples)
    worst = {}
    for kind, points in _spread_points(verb).items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", AdverbsWarning)  # 25% past is "far outside" on purpose
            speeds = [_largest_joint_speed(verb.synthesize(p, cycles=1, fps=120)[0]) for p in points]
        worst[kind] = max(speeds) / own
    assert all(w <= 1.5 for w in worst.values()), worst
    return worst


@pytest.mark.parametrize("name", VERB_SPECS)
def test_no_joint_outruns_the_examples_at_120_fps(verbs, name):
    _check_speeds(*verbs[name])


@pytest.mark.parametrize("name", RUN_SPECS)
def test_no_joint_outruns_the_examples_in_the_runs(run_verbs, name):
    verb, examples = run_verbs[name]
    assert np.diff(verb.keytimes_table * verb.fps, axis=1).min() <= 1.0  # toe-offs a frame or less from strikes
    _check_speeds(verb, examples)


@pytest.mark.parametrize("name", TOE_OFF_SPECS)
def test_no_joint_outruns_the_examples_with_toe_off_keytimes(toe_off_verbs, name):
    verb, examples = toe_off_verbs[name]
    assert verb.num_keytimes == 5 and "toe-off" in " ".join(verb.keytime_names)
    k = verb.keytimes_table * verb.fps
    assert np.diff(k, axis=1).min() <= 1.0  # intervals of a frame or less: what used to explode
    _check_speeds(verb, examples)


def test_the_paper_s_even_spacing_fits_worse(toe_off_verbs):
    """Why generic keytimes follow the examples: evenly spaced, the same examples' curves move faster between frames.

    Fitted to the frames alone, evenly spaced keytimes swung between frames (over 3x the examples'
    fastest joint). Fitted to the frames joined, they no longer swing that far, but still 1.44x against
    the examples' spacing's 1.01x under the paper's warp, 1.21x under ours (measured), and the build warns.
    """
    verb, examples = toe_off_verbs["cmu_walk"]
    spec = load_spec(SPECS / "cmu_walk.toml")
    with pytest.warns(AdverbsWarning, match="faster between frames"):
        even = build_verb(
            "even", examples, [*verb.adverbs], spec["num_cp"], spec["encoding"], True, keytime_spacing="even"
        )
    own = max(_largest_joint_speed(ex.clip) for ex in examples)
    fastest = max(_largest_joint_speed(even.synthesize(p, cycles=1, fps=120)[0]) for p in even.points)
    ours = max(_largest_joint_speed(verb.synthesize(p, cycles=1, fps=120)[0]) for p in verb.points)
    assert fastest > 1.15 * own and fastest > 1.15 * ours


@pytest.mark.parametrize("name", VERB_SPECS + RUN_SPECS)
def test_between_frames_the_fits_follow_the_examples(verbs, run_verbs, name):
    """Fitted to the frames alone, an example whose keytime interval is a frame long where the others' are
    several overshot between those two frames: CMU's "jog turn right" put a toe 191 mm off its path for
    1/30 s, Bandai's "proud" run 113 mm (6-9x the fit's error at the frames), and the shipped runs warned
    that their fits could not be trusted. Fitted to the frames joined, no example departs from its path
    between frames by more than 1.5x what it does at the frames (at most 1.46x, measured), and no joint
    moves fast enough between frames for the build to warn. (Bounded by the verb's worst fit at its frames since
    the warp turns its rate smoothly at keytimes: CMU's "run turn right" fits its frames better, 2.84 -> 2.05 cm,
    and between them about as before, 3.30 -> 3.46 cm, 1.69x its own.)
    """
    verb, examples = {**verbs, **run_verbs}[name]
    assert [x.name for x in verb.examples] == [ex.name for ex in examples]
    worst = max(x.fit_error for x in verb.examples)
    for i, (x, ex) in enumerate(zip(verb.examples, examples)):
        assert x.fine_error <= 1.5 * worst, x
        k, num_cp = verb.keytimes_table[i], verb.coefficients.shape[1]
        coefficients, *_, speed = fit._fit_example(verb.encoding, ex.clip, k, verb.generic_keytimes, num_cp)
        np.testing.assert_array_equal(coefficients, verb.coefficients[i])  # the fit the verb was built with
        assert speed < fit.SPEED_WARNING, (x.name, speed)


def test_fit_errors_are_reported_between_frames(verbs):
    for verb, _ in verbs.values():
        for x in verb.examples:
            assert 0.0 < x.fine_error < 0.05, x  # the pose on a 4x finer grid, metres
            assert 0.0 < x.fit_error < 0.05, x


def test_regularized_fit_is_exact_on_lines_and_well_posed_with_no_samples_in_a_span():
    t = np.concatenate([np.linspace(0.0, 0.3, 20), np.linspace(0.7, 1.0, 20)])  # nothing in (0.3, 0.7)
    line = np.stack([2.0 * t - 1.0, 0.5 * t], axis=1)
    coef, resid = bspline.fit(t, line, 16, smoothing=1e-4)
    np.testing.assert_allclose(resid, 0.0, rtol=0, atol=1e-12)
    dense = np.linspace(0, 1, 401)
    np.testing.assert_allclose(bspline.evaluate(coef, dense)[:, 0], 2.0 * dense - 1.0, rtol=0, atol=1e-10)
    wiggly = np.sin(9.0 * t)[:, None]
    b = bspline.design_matrix(t, 16)
    assert np.linalg.cond(b.T @ b) > 1e12  # plain least squares: (nearly) singular
    assert np.linalg.cond(bspline.normal_matrix(b, 1e-4)) < 1e9
    coef, _ = bspline.fit(t, wiggly, 16, smoothing=1e-4)
    assert np.abs(bspline.evaluate(coef, dense)).max() < 1.5  # no swing where there are no samples


def test_generic_keytimes_round_trip_and_reproduce_the_paper_when_even():
    k = np.array([[0.0, 0.01, 0.5, 0.52, 1.0], [0.0, 0.05, 0.6, 0.7, 1.2]])
    g = timewarp.examples_spacing(k)
    assert g[0] == 0.0 and g[-1] == 1.0 and np.all(np.diff(g) > 0)
    clocks = np.linspace(0, 1.2, 50)
    np.testing.assert_allclose(timewarp.clock_time(timewarp.generic_time(clocks, k[1], g), k[1], g), clocks, rtol=0, atol=1e-12)
    np.testing.assert_allclose(timewarp.generic_time(k[1], k[1], g), g, rtol=0, atol=1e-15)
    even = timewarp.generic_time(clocks, k[1], timewarp.even_spacing(5))
    np.testing.assert_allclose(even, timewarp.generic_time(clocks, k[1]), rtol=0, atol=1e-15)
    with pytest.raises(AdverbsError, match="increasing"):
        timewarp.check_generic(np.array([0.0, 0.6, 0.5, 0.8, 1.0]), 5)


def test_too_many_control_points_names_the_example_and_the_field(tmp_path):
    text = (SPECS / "cmu_walk.toml").read_text().replace("num_cp = 16", "num_cp = 40")
    text = text.replace('"../data/', f'"{SPECS.parent / "data"}/')
    path = tmp_path / "walk.toml"
    path.write_text(text)
    spec = load_spec(path)
    examples, adverbs = examples_from_spec(spec)
    shortest = min(examples, key=lambda x: x.clip.num_frames)
    with pytest.raises(SpecError) as e:
        from adverbs import build_from_spec

        build_from_spec(path)
    msg = str(e.value)
    assert e.value.field == "num_cp" and e.value.example is not None
    assert "too few to fit num_cp = 40" in msg and f"at most {shortest.clip.num_frames}" in msg


def _root_path_rates(verb, p, cycles=6, make=None):
    """Speed (m/s) and turn rate (deg/s) in steady state, from the body root's path alone.

    Repeated cycles are rigid copies of each other, so the body root's ground positions at the cycle
    starts lie on a circle (a line when the walk goes straight): the angle between consecutive chords
    is one cycle's turn, and the speed is the turn rate times the body root's mean distance from the
    circle's centre (the chord over the period when it goes straight). The first cycle is left out
    (the seam blend begins with the second). ``make(verb, p, cycles)`` gives the clip and keytimes (default:
    ``verb.synthesize``).
    """
    clip, k = (make or (lambda v, q, n: v.synthesize(q, cycles=n)))(verb, p, cycles)
    period = k[-1]
    root = clip.global_positions()[:, verb.encoding.body_root][:, [0, 2]]
    time = np.arange(clip.num_frames) / clip.fps
    starts = np.stack([np.interp(np.arange(1, cycles + 1) * period, time, root[:, i]) for i in range(2)], axis=1)
    chords = np.diff(starts, axis=0)
    turn = np.mean(np.diff(np.unwrap(np.arctan2(chords[:, 0], chords[:, 1]))))
    if abs(turn) < np.deg2rad(1.0):
        return np.linalg.norm(chords, axis=1).mean() / period, np.rad2deg(turn) / period
    # The circle through the starts: |x − c|² = r² is linear in (c, r² − |c|²).
    a = np.column_stack([2.0 * starts, np.ones(len(starts))])
    centre = np.linalg.lstsq(a, np.sum(starts**2, axis=1), rcond=None)[0][:2]
    steady = root[time >= period]
    return abs(turn) / period * np.linalg.norm(steady - centre, axis=1).mean(), np.rad2deg(turn) / period


@pytest.mark.parametrize("name", [n for n in VERB_SPECS if n != "bandai_reach"] + RUN_SPECS)
def test_repeated_cycles_keep_the_asked_speed_and_turn(verbs, run_verbs, name):
    verb, _ = verbs[name] if name in verbs else run_verbs[name]
    names = verb.adverb_names
    kinds = {a.name: (a.measure or {}).get("kind") for a in verb.adverbs}
    span = np.ptp(verb.points, axis=0)
    checked = 0
    for p in verb.points:
        speed, turn = _root_path_rates(verb, p)
        for i, a in enumerate(names):
            if kinds[a] == "speed":
                assert abs(speed - p[i]) <= 0.03 * span[i], (a, p, speed)
                checked += 1
            elif kinds[a] == "turn_rate":
                assert abs(turn - p[i]) <= 0.03 * span[i], (a, p, turn)
                checked += 1
    assert checked >= len(verb.points)
