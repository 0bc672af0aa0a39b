"""The goal chain's solve (:mod:`adverbs.verb.goal`): the compiled kernel is the NumPy reference, on the shipped reach.

The kernel (:mod:`adverbs.verb._goal_kernel`) computes the reference's model with less arithmetic (the root's
velocities blended per control point, the pose at the keytime from per-verb tables, forward kinematics down the goal
joint's ancestors only, the Levenberg–Marquardt step through a 3 × 3 system): the same offsets to rounding. Where the
solve stops on its settling rule (a step lowering the cost by less than 1e-10 of it), rounding may move that stop by a
step along the chain's flat directions: measured on 8,000 uniform points (inside the examples' box and 25%, 60% and
100% past it) one in 2,000 differs by more than 1e-10 (at most 2.6e-10), and among the obedience points between and
25% past the examples one each by 7.8e-10 and 6.6e-10 — nanometres at the hand. Goals far out of reach end where the
40 steps leave them, offsets of radians, with rounding carried through 40 large steps: up to 1.5e-7 apart on points 4
times the examples' span past them and for a goal 2 m in front of the body.
"""

from __future__ import annotations

import dataclasses
import multiprocessing

import numpy as np
import pytest

from adverbs.apps.evaluate import obedience_points
from adverbs.verb import _goal_kernel
from adverbs.verb import goal as goals

AGREE = 1e-8  # radians: compiled and reference offsets at most this far apart (measured: 7.8e-10)
AGREE_FAR = 1e-6  # for goals far out of reach, where the solve stops at its 40 steps (measured: 1.5e-7)


@pytest.fixture(scope="module")
def reach(verbs):
    verb, _ = verbs["bandai_reach"]
    return verb


def _points(verb, seed: int = 0) -> dict[str, np.ndarray]:
    """Adverb points of every kind: the examples, the obedience points, uniform in the examples' box and 25% and 60%
    past it, and goals no arm gets to (3 m up, a metre out to the side, 2 m in front)."""
    rng = np.random.default_rng(seed)
    lo, hi = verb.points.min(axis=0), verb.points.max(axis=0)
    top = verb.points[np.argmax(verb.points[:, 1])]
    out = {"examples": verb.points, **obedience_points(verb)}
    for name, past in (("inside", 0.0), ("25% past", 0.25), ("60% past", 0.6)):
        out[f"uniform {name}"] = rng.uniform(lo - past * (hi - lo), hi + past * (hi - lo), (200, len(lo)))
    out["out of reach"] = np.array([[top[0], 3.0, top[2]], [top[0] - 1.0, top[1], top[2]], [top[0], top[1], 2.0]])
    return out


def _both(verb, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    state = verb.state(len(points))
    state.update(verb, points)
    args = (verb, verb.goal, state.weights, state.keytimes, points)
    return goals.solve(*args), goals.solve(*args, compiled=False)


def _miss(verb, points: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """How far the goal joint lands from its aim ``(P,)`` with ``offsets``, in the reference's model."""
    state = verb.state(len(points))
    state.update(verb, points)
    model = goals._Model(verb, verb.goal, state.weights, state.keytimes)
    at, _ = model.reached(np.arange(len(points)), offsets)
    return np.linalg.norm(points + state.weights @ verb.goal_misses - at, axis=1)


def test_the_compiled_solve_is_the_reference(reach):
    for kind, points in _points(reach).items():
        compiled, reference = _both(reach, points)
        atol = AGREE_FAR if kind == "out of reach" else AGREE
        np.testing.assert_allclose(compiled, reference, rtol=0, atol=atol, err_msg=kind)
    # The points checked include goals the arm cannot reach (the solve ends at the arm's nearest, centimetres off)
    # and goals it reaches (to the tenth of a millimetre the pull towards no offset leaves).
    past = _points(reach)["uniform 60% past"]
    miss = _miss(reach, past, _both(reach, past)[0])
    assert (miss > 0.01).sum() >= 20 and (miss < 1e-3).sum() >= 20


def test_no_offset_at_the_examples(reach):
    compiled, reference = _both(reach, reach.points)
    assert np.all(compiled == 0.0) and np.all(reference == 0.0)


@pytest.fixture(scope="module")
def standing_reach(tmp_path_factory):
    """The shipped reach standing on its feet (``in_place = "feet"``): its root the centre of its stance."""
    import warnings

    from conftest import on_their_feet

    from adverbs.verb import build_from_spec

    specs = on_their_feet(tmp_path_factory.mktemp("standing"), ["bandai_reach"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return build_from_spec(specs / "bandai_reach.toml")


def test_a_reach_standing_on_its_feet_solves_as_the_reference_and_puts_the_hand_on_its_goal(standing_reach):
    """Standing on its feet, the reach's hips sway over them in the pose (``<body root>.tx``, ``.tz``) and its root
    does not travel; the goal is measured as ever, from the hips' ground point at the start. The compiled solve is the
    reference, no offset at the examples, and the synthesized motion puts the hand where the adverbs ask."""
    from adverbs.verb.measures import measure_all

    verb = standing_reach
    assert verb.encoding.anchored and not verb.root_velocity_samples.any()
    points = _points(verb)
    for kind in ("uniform inside", "uniform 25% past"):
        compiled, reference = _both(verb, points[kind])
        np.testing.assert_allclose(compiled, reference, rtol=0, atol=AGREE, err_msg=kind)
    compiled, reference = _both(verb, verb.points)
    assert np.all(compiled == 0.0) and np.all(reference == 0.0)
    measures = [a.measure for a in verb.adverbs]
    for p in points["uniform inside"][:6]:
        clip, keys = verb.synthesize(p, fps=60.0)
        np.testing.assert_allclose(measure_all(clip, keys, measures), p, rtol=0, atol=0.003)


def test_a_gapped_or_reordered_chain_is_solved_as_the_reference_solves_it(reach):
    # Joints of the goal joint's ancestors left out of the chain (Spine, Shoulder_R, LowerArm_R) keep the pose's
    # rotation; a chain listed hand first has its offset's blocks in that order; the hand itself in the chain turns
    # about its own joint and does not move (its block stays zero).
    points = np.concatenate([v[:40] for k, v in _points(reach, seed=1).items() if k != "out of reach"])
    chains = (("Chest", "UpperArm_R"), ("LowerArm_R", "UpperArm_R", "Shoulder_R", "Chest", "Spine"),
              ("UpperArm_R", "Hand_R", "LowerArm_R"))  # fmt: skip
    for chain in chains:
        verb = dataclasses.replace(reach, goal_chain=chain)
        compiled, reference = _both(verb, points)
        np.testing.assert_allclose(compiled, reference, rtol=0, atol=AGREE, err_msg=str(chain))
        assert np.abs(compiled).max() > 0.1
        if "Hand_R" in chain:
            assert np.all(compiled[:, 3:6] == 0.0)


def test_degenerate_points_get_no_offset(reach):
    # Keytimes that are not finite, do not increase or run past 10⁶ s, and weights that are not finite: no offset
    # (synthesis refuses such points; a run-time creature is not stopped by them). The rest of the batch is solved
    # as it would be alone.
    points = _points(reach)["uniform inside"][:6]
    state = reach.state(len(points))
    state.update(reach, points)
    w, k = state.weights.copy(), state.keytimes.copy()
    k[0, 1] = np.nan
    k[1, 2] = k[1, 1]
    k[2] *= 1e7
    w[3, 0] = np.inf
    for compiled in (True, False):
        got = goals.solve(reach, reach.goal, w, k, points, compiled=compiled)
        assert np.all(got[:4] == 0.0)
        alone = goals.solve(reach, reach.goal, w[4:], k[4:], points[4:], compiled=compiled)
        np.testing.assert_array_equal(got[4:], alone)
        assert np.abs(got[4:]).max() > 0.0


def test_one_thread_or_many_and_one_row_or_many_give_the_same_bits(reach, monkeypatch):
    points = _points(reach)["uniform 25% past"]
    state = reach.state(len(points))
    state.update(reach, points)
    args = (reach, reach.goal, state.weights, state.keytimes, points)
    runs = {}
    for threads in (1, 2, 3):
        monkeypatch.setattr(goals, "THREADS", threads)
        runs[threads] = goals.solve(*args)
    alone = np.concatenate([goals.solve(reach, reach.goal, state.weights[i : i + 1], state.keytimes[i : i + 1],
                                        points[i : i + 1]) for i in range(0, len(points), 37)])  # fmt: skip
    np.testing.assert_array_equal(runs[1], runs[2])
    np.testing.assert_array_equal(runs[1], runs[3])
    np.testing.assert_array_equal(runs[1][::37], alone)


def test_a_creature_solves_its_point_afresh_whatever_it_passed_through(reach):
    # No warm start: the solve at a point is the same however the creature got there. (Started from the last
    # solution, the Levenberg–Marquardt ends elsewhere along the chain's flat directions: on a goal moved 5 mm a frame
    # for 30 frames, up to 0.12 rad away inside the examples' box and 0.59 rad 25% past it; see the module.)
    rng = np.random.default_rng(5)
    lo, hi = reach.points.min(axis=0), reach.points.max(axis=0)
    walk = np.clip(rng.uniform(lo, hi, (8, 3)) + np.cumsum(rng.normal(0, 0.005, (12, 8, 3)), axis=0), lo, hi)
    moving = reach.state(8)
    for points in walk:
        moving.update(reach, points)
        fresh = reach.state(8)
        fresh.update(reach, points)
        np.testing.assert_array_equal(moving.goal, fresh.goal)


def test_the_keytime_pose_tables_hold_at_every_point(reach):
    # The kernel's tables read the keytime's pose off the verb once: the clock time of a keytime is its generic time
    # at any adverb point (the B-spline segment and basis are the verb's). Built from any point's keytimes, the same.
    _, rot_col, trans_col, *_, body = reach.goal.path[:7]
    cols = np.array([3, *range(rot_col[body], rot_col[body] + 3)], dtype=np.int64)
    points = _points(reach)["uniform 60% past"][:20]
    first = None
    for k in np.concatenate([reach.keytimes_table, reach.keytimes(points)]):
        got = _goal_kernel.tables(
            reach.segments, k[None], reach.generic_keytimes, reach.goal.keytime, goals._GRID, cols, cols
        )  # fmt: skip
        if first is None:
            first = got
        for a, b in zip(got, first):
            np.testing.assert_array_equal(a, b)


def _solve_in_child(verb, points):
    state = verb.state(len(points))
    state.update(verb, points)
    return state.goal


def test_a_forked_process_solves_on_threads_of_its_own(reach, monkeypatch):
    # The threads a crowd's solve runs on are made once per process: a child forked after the parent made them (a
    # multiprocessing pool on Linux) has none of them, and solving on the parent's pool would wait forever.
    monkeypatch.setattr(goals, "THREADS", 2)
    points = _points(reach)["uniform inside"]
    here = _solve_in_child(reach, points)
    with multiprocessing.get_context("fork").Pool(1) as pool:
        there = pool.apply_async(_solve_in_child, (reach, points)).get(timeout=120)
    np.testing.assert_array_equal(there, here)
