"""The shipped reach (specs/bandai_reach.toml): the hand goes where it is asked.

Goal error: the distance from the right hand of the synthesized motion (the verb's own, goal correction
included) at its peak keytime to the asked goal, both in the measure's frame (the character's starting
frame), measured as the examples are (:func:`adverbs.verb.measures.measure_all`). It is checked at the
points :func:`adverbs.apps.evaluate.obedience_points` gives: the examples, halfway between each and its
nearest neighbour, and 25% past them (``c + 1.25 (p_i − c)``); and at takes the spec leaves out.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from conftest import BANDAI, SPECS

from adverbs.apps.evaluate import measure_point, obedience_points
from adverbs.verb.examples import examples_from_spec
from adverbs.verb.measures import measure_all
from adverbs.feet.measures import foot_drift
from adverbs.feet.offline import plant_feet
from adverbs.verb.spec import load_spec

GOAL = ("hand_x", "hand_y", "hand_z")
# Largest goal error (metres) at each kind of point, the issue's; measured: 1.0 mm, 1.1 mm and 34.5 mm.
TOLERANCE = {"at examples": 0.005, "between": 0.02, "25% past": 0.05}


def goal_errors(verb, points: np.ndarray) -> np.ndarray:
    """Distance ``(P,)`` from the synthesized hand at the peak keytime to each asked goal ``points (P, 3)``, m."""
    return np.array([np.linalg.norm(measure_point(verb, p) - p) for p in points])


@pytest.fixture(scope="module")
def reach(verbs):
    verb, _ = verbs["bandai_reach"]
    assert verb.adverb_names == GOAL and all(a.measure["kind"] == "joint_position" for a in verb.adverbs)
    return verb


@pytest.fixture(scope="module")
def errors(reach):
    return {kind: goal_errors(reach, pts) for kind, pts in obedience_points(reach).items()}


def test_the_goals_span_low_to_high_reaches(reach):
    styles = {Path(x.source).stem.split("_")[-2] for x in reach.examples}
    assert styles == {"elderly", "exhausted", "normal", "youthful"}
    # The examples' goals: 1.27 m (elderly) to 1.78 m (youthful) high, 51 cm, and 27 cm front to back.
    span = np.ptp(reach.points, axis=0)
    assert span[1] >= 0.30 and span[2] >= 0.10
    # The goals checked below (at, between and 25% past the examples) span 64 cm in height.
    checked = np.concatenate(list(obedience_points(reach).values()))
    assert np.ptp(checked[:, 1]) >= 0.6


@pytest.mark.parametrize("kind", list(TOLERANCE))
def test_the_hand_reaches_the_goal(errors, kind):
    assert errors[kind].max() <= TOLERANCE[kind], f"{kind}: {1000 * errors[kind].max():.1f} mm"


def test_the_hand_reaches_the_goals_of_held_out_takes(reach):
    # The normal takes the spec leaves out (near-duplicates of kept ones), measured the way the spec's
    # examples are: the verb asked for each one's goal puts the hand there (measured: within 1 mm).
    spec = load_spec(SPECS / "bandai_reach.toml")
    used = {Path(x["file"]).name for x in spec["examples"]}
    held = [p for p in sorted(BANDAI.glob("dataset-2_raise-up-right-hand_normal_*.bvh")) if p.name not in used]
    assert len(held) == 6
    spec["examples"] = [{"name": p.stem, "file": str(p), "keytimes": {"peak": "Hand_R"}} for p in held]
    goals = np.array([x.point for x in examples_from_spec(spec)[0]])
    assert goals.shape == (6, 3)
    assert goal_errors(reach, goals).max() <= 0.005


def test_without_the_goal_chain_the_blend_misses(reach):
    # The same tables played without the correction: the youthful takes' straight arms pull the blends
    # off (measured: 25 mm between examples, 25 cm 25% past them). The chain is what puts the hand there.
    bare = dataclasses.replace(reach, goal_chain=())
    assert bare.goal is None
    points = obedience_points(reach)
    assert goal_errors(bare, points["between"]).max() > TOLERANCE["between"]
    assert goal_errors(bare, points["25% past"]).max() > 0.1


def test_past_the_quickest_takes_the_reach_is_no_quicker(reach):
    # timing = "clamp": 25% past the examples the hand goes further, but the raise and the lowering each last
    # no less (and no more) than some take's; at the examples the keytimes are their own. Every path agrees.
    points = obedience_points(reach)["25% past"]
    own = np.diff(reach.keytimes_table, axis=1)
    steps = np.diff(reach.keytimes(points), axis=1)
    assert np.all(steps >= own.min(axis=0) * (1 - 1e-12)) and np.all(steps <= own.max(axis=0) * (1 + 1e-12))
    np.testing.assert_allclose(reach.keytimes(reach.points), reach.keytimes_table, rtol=0, atol=1e-9)
    state = reach.state(len(points))
    state.update(reach, points)
    np.testing.assert_allclose(state.keytimes, reach.keytimes(points), rtol=0, atol=1e-12)
    # The paper's timing extrapolates the trend of the takes (the higher, the quicker): past the youthful
    # takes it raises the hand in 0.40 s where the quickest take took 0.60 s.
    free = dataclasses.replace(reach, timing="extrapolate")
    assert np.diff(free.keytimes(points), axis=1)[:, 0].min() < 0.75 * own[:, 0].min()


def test_a_goal_out_of_reach_leaves_the_arm_at_its_nearest(reach):
    # 3 m up and 1 m out to the side: no arm gets there. The solve ends with a bounded offset (no runaway),
    # and the hand goes nearer the goal than the uncorrected blend puts it.
    top = reach.points[np.argmax(reach.points[:, 1])]
    bare = dataclasses.replace(reach, goal_chain=())
    for far in (np.array([top[0], 3.0, top[2]]), np.array([top[0] - 1.0, top[1], top[2]])):
        state = reach.state()
        state.update(reach, far[None])
        assert np.all(np.isfinite(state.goal)) and np.abs(state.goal).max() < np.pi
        assert np.linalg.norm(measure_point(reach, far) - far) < np.linalg.norm(measure_point(bare, far) - far)


def test_planted_feet_leave_the_hand_where_it_was(reach):
    # At the lowest and the highest goal checked (25% past the examples), the feet are held by IK on the
    # legs and the hand at the peak keytime stays where the motion put it. At the lowest: feet within
    # 1 mm, hand unmoved. At the highest (1.85 m, past the youthful takes) the extrapolated stance is too
    # tall for the legs: the planter lowers the body 9 mm, the hand with it (still within the 25%-past
    # tolerance of the goal), and the right foot turns about its held ankle, its toe drifting 8 mm (the
    # verb's own: 9 mm); a known limit of planting a stance far outside its examples (noted on issue 8).
    past = obedience_points(reach)["25% past"]
    hand, body = reach.skeleton.index("Hand_R"), reach.skeleton.index("Hips")
    measures = [a.measure for a in reach.adverbs]
    for p, drift, drop in zip(past[[np.argmin(past[:, 1]), np.argmax(past[:, 1])]], (1e-3, 0.01), (1e-3, 0.012)):
        clip, k = reach.synthesize(p)
        planted, _ = plant_feet(reach, clip, k)
        assert foot_drift(reach, planted, k).max() <= drift
        peak = int(round(k[1] * clip.fps))
        moved = planted.global_positions()[peak] - clip.global_positions()[peak]
        np.testing.assert_allclose(moved[hand], moved[body], rtol=0, atol=1e-6)  # the arm is the motion's
        assert np.linalg.norm(moved[body]) <= drop
        assert np.linalg.norm(measure_all(planted, k, measures) - p) <= TOLERANCE["25% past"]
