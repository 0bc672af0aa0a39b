"""Cycles after cycles through the verb's own loop into itself (§5): what `adverbs synth --cycles` writes.

A cyclic verb played for more than one cycle goes through :func:`adverbs.graph.performance.repeat`: the verb
as a graph of its own, each cycle blending into the next by its self-transition, the feet planted by the
graph's planter. These tests hold it to the verb (frame for frame until the first loop begins), to the asked
speed and turn in steady state measured from the root path alone, to smooth seams and to the floor, and the
command line to the library.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import RUN_SPECS, SPECS, VERB_SPECS
from test_cli import run
from test_fits import _largest_joint_speed, _root_path_rates

from adverbs import read_bvh
from adverbs.graph import Graph
from adverbs.graph.performance import perform, repeat
from adverbs.graph.player import first_frame, step
from adverbs.graph.state import new_state
from adverbs.graph.structure import LOOP, loop_region
from adverbs.interp.timewarp import clock_time
from adverbs.feet.measures import measure_feet
from adverbs.feet.planter import effector_joints

CYCLIC = [n for n in VERB_SPECS if n != "bandai_reach"] + RUN_SPECS


def _verb(verbs, run_verbs, name):
    return (verbs[name] if name in verbs else run_verbs[name])[0]


def _points(verb):
    """An example, the middle of two examples far apart, and the examples' mean."""
    far = np.argmax(np.linalg.norm(verb.points - verb.points[0], axis=1))
    return [verb.points[0], (verb.points[0] + verb.points[far]) / 2, verb.points.mean(axis=0)]


def _looped_clip(verb, p, cycles):
    """``repeat``'s unplanted clip and one cycle's keytimes, as ``_root_path_rates`` takes them."""
    performance, keytimes = repeat(verb, p, cycles=cycles)
    return performance.free, keytimes


@pytest.mark.parametrize("name", CYCLIC)
def test_a_loop_plays_the_verb_itself_until_its_first_blend(verbs, run_verbs, name):
    verb = _verb(verbs, run_verbs, name)
    for p in _points(verb):
        looped, k = repeat(verb, p, cycles=3)
        one, k1 = verb.synthesize(p, cycles=1)
        three, _ = verb.synthesize(p, cycles=3)
        np.testing.assert_array_equal(k, k1)
        assert looped.free.num_frames == three.num_frames and looped.free.fps == three.fps
        # Until the loop's region begins, frame for frame the verb.
        begins = np.interp(loop_region(verb)[0], verb.generic_keytimes, k)
        before = np.arange(one.num_frames) / one.fps < begins - 1e-9
        assert before.sum() >= 0.6 * one.num_frames
        a = looped.free.global_positions()[: one.num_frames][before]
        b = one.global_positions()[before]
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-9)
        # After it, the cycles differ from the seam fade's: the blend is the graph's.
        assert np.abs(looped.free.global_positions() - three.global_positions()).max() > 1e-3


@pytest.mark.parametrize("name", CYCLIC)
def test_the_loop_is_the_last_quarter_of_the_cycle_in_clock_time(verbs, run_verbs, name):
    """Not of generic time: a run's last keytime interval (toe-off to strike) can be two frames."""
    verb = _verb(verbs, run_verbs, name)
    start, end = loop_region(verb)
    assert end == 1.0 and Graph.of_verb(verb).transitions[0].source_region == (start, end)
    k = verb.keytimes(verb.points.mean(axis=0))
    assert clock_time(start, k, verb.generic_keytimes) == pytest.approx((1.0 - LOOP) * k[-1], rel=1e-12)


@pytest.mark.parametrize("name", CYCLIC)
def test_looped_cycles_keep_the_asked_speed_and_turn(verbs, run_verbs, name):
    """The steady-state check of the seam fade (test_fits), on the loop: from the root path alone, every example's
    speed and turn within 3.5% of the examples' range of the asked value. (The seam fade is held to 3%. Over the
    shipped cyclic verbs the loop is as near as the fade or nearer but for the slow sharp CMU turn, the worst of
    both: -3.0% faded, -3.2% looped. The two spread one seam differently over the cycle, and the body's sway
    moves the radius this measure reads.)"""
    verb = _verb(verbs, run_verbs, name)
    kinds = {a.name: (a.measure or {}).get("kind") for a in verb.adverbs}
    span = np.ptp(verb.points, axis=0)
    checked = 0
    for p in verb.points:
        looped = _root_path_rates(verb, p, make=_looped_clip)
        for i, a in enumerate(verb.adverb_names):
            kind = {"speed": 0, "turn_rate": 1}.get(kinds[a])
            if kind is not None:
                assert abs(looped[kind] - p[i]) <= 0.035 * span[i], (a, p, looped)
                checked += 1
    assert checked >= len(verb.points)


@pytest.mark.parametrize("name", CYCLIC)
def test_the_loop_is_smooth_and_the_planted_feet_stay_on_the_floor(verbs, run_verbs, name):
    verb = _verb(verbs, run_verbs, name)
    for p in _points(verb):
        looped, k = repeat(verb, p, cycles=4)
        own, _ = verb.synthesize(p, cycles=1)
        # No joint moves faster through the seams than 1.5x the verb's own fastest in one cycle.
        assert _largest_joint_speed(looped.free) <= 1.5 * _largest_joint_speed(own)
        # The root carries on: no frame's step is longer than 1.5x the fastest the verb's root goes.
        root = looped.free.global_positions()[:, verb.encoding.body_root][:, [0, 2]]
        steps = np.linalg.norm(np.diff(root, axis=0), axis=1)
        own_root = own.global_positions()[:, verb.encoding.body_root][:, [0, 2]]
        assert steps.max() <= 1.5 * np.linalg.norm(np.diff(own_root, axis=0), axis=1).max()
        # Planted: held toes still (≤ 1 cm), and no toe goes below the floor (1 mm).
        metrics = measure_feet(verb, looped.planted, looped.report)
        assert len(metrics.toe_drift) >= 4 and metrics.toe_drift.max() <= 0.01
        toes = looped.planted.global_positions()[:, effector_joints(verb), 1]
        assert toes.min() >= verb.floor - 1e-3


def test_the_first_frame_is_where_the_verb_starts_and_steps_carry_on_from_it(verbs):
    verb = verbs["bandai_styled_walk"][0]
    graph = Graph.of_verb(verb)
    p = verb.points[3]
    one, _ = verb.synthesize(p, cycles=1)
    started = perform(graph, seconds=0.5, fps=verb.fps, adverbs=dict(zip(verb.adverb_names, p)), from_start=True)
    plain = perform(graph, seconds=0.5, fps=verb.fps, adverbs=dict(zip(verb.adverb_names, p)))
    assert started.free.num_frames == plain.free.num_frames + 1
    np.testing.assert_allclose(started.free.global_positions(), one.global_positions()[: started.free.num_frames], rtol=0, atol=1e-9)
    # With or without a first frame, the steps after it are the same frames.
    np.testing.assert_allclose(started.free.global_positions()[1:], plain.free.global_positions(), rtol=0, atol=1e-9)
    state = new_state(graph, 1, points=graph.point(dict(zip(verb.adverb_names, p)))[None])
    step(state, 1.0 / verb.fps)
    with pytest.raises(Exception, match="already moved"):
        first_frame(state)


@pytest.mark.parametrize("method", ["linear", "nearest", "idw"])
def test_another_interpolator_plays_as_a_verb_of_one_example(verbs, method):
    """`Verb.playing`: a prediction played by everything a verb is played by — at an example, the example."""
    from adverbs.apps.evaluate import predict

    verb = verbs["cmu_walk"][0]
    e = 4
    at = verb.playing(verb.coefficients[e], verb.keytimes_table[e], verb.points[e])
    a, _ = at.synthesize(verb.points[e], cycles=2)
    b, _ = verb.synthesize(verb.points[e], cycles=2)
    np.testing.assert_allclose(a.global_positions(), b.global_positions(), rtol=0, atol=1e-9)
    p = (verb.points[0] + verb.points[5]) / 2
    cp, k = predict(method, verb, p)
    one = verb.playing(cp, k, p, name=method)
    assert one.name == method and len(one.examples) == 1
    np.testing.assert_allclose(one.control_points(p + 0.3), cp, rtol=0, atol=1e-12)  # whatever its adverbs
    looped, k2 = repeat(one, p, cycles=2)
    np.testing.assert_array_equal(k2, k)
    with pytest.raises(Exception, match="do not fit"):
        verb.playing(cp[:-1], k, p)


def test_synth_cycles_writes_the_loop(tmp_path, verbs):
    verb_file = tmp_path / "walk.verb"
    assert run("build", SPECS / "cmu_walk.toml", "-o", verb_file).returncode == 0
    verb = verbs["cmu_walk"][0]
    p = {"speed": 1.4, "turn": -20.0}
    args = [f"--adverb=speed={p['speed']}", f"--adverb=turn={p['turn']}", "--cycles", "3"]
    for extra, which in (([], "planted"), (["--no-ik"], "free")):
        out = tmp_path / f"{which}.bvh"
        r = run("synth", verb_file, *args, *extra, "-o", out)
        assert r.returncode == 0, r.stderr
        looped, _ = repeat(verb, verb.point(p), cycles=3)
        want = getattr(looped, which).global_positions()
        got = read_bvh(out).global_positions()
        assert got.shape == want.shape
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-4)  # the BVH's six decimals of centimetres
    # A comparison method loops the same way, as a one-example verb.
    r = run("synth", verb_file, *args, "--method", "idw", "-o", tmp_path / "idw.bvh")
    assert r.returncode == 0 and "by idw" in r.stdout, r.stderr
