"""The arms carried past a short blend from one cycle into another (issue 32).

A walk's and a run's feet agree over a quarter of their cycles, so the graphs blend them over 0.2-0.3 s; the CMU
run's forearms are bent 80° more than the walk's, and through those blends they turned at 2.5-3.9x their verbs' own
fastest. Now the arms play the verb entered at once and carry the difference from the pose shown on, fading over
``ARMS_BLEND`` (``player._arms``). These tests drive one creature frame by frame through
such blends, one of them turned back half-way and one cut short by a command that leaves the blend, on the readable
path and the compiled pass, and measure the frames.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from adverbs import load_graph
from adverbs.errors import AdverbsWarning
from adverbs.graph import queue
from adverbs.graph.player import step
from adverbs.graph.queue import command
from adverbs.graph.state import ARMS_BLEND, new_state
from adverbs.runtime.frame import FramePass

from test_edges import _angular_speed, _parts

GRAPHS = Path(__file__).resolve().parent.parent / "graphs"
DT = 1.0 / 30.0


@pytest.fixture(scope="module")
def graphs():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        return {name: load_graph(GRAPHS / f"{name}.toml") for name in ("bandai", "cmu")}


def _drive(graph, plan, seconds, compiled=False, points=None):
    """One creature from the walk, told what ``plan`` says: ``[(when, verb)]``, ``when`` a time in seconds or
    ``("mid", source, target)``: as soon as a blend from ``source`` into ``target`` is half-way (``"begun"``: under
    way). Returns the
    rotations shown ``(F, J, 4)``, each frame's transition and the verb it is entered from, whether each frame took the
    arms' offset (1) or ended it (−1), and the final state."""
    state = new_state(graph, 1, seed=5, start="walk", points=points, stay=True)
    frames = FramePass(state) if compiled else None
    names = graph.verb_names
    todo = list(plan)
    out, active, source, took = [], [], [], []
    for f in range(int(round(seconds / DT))):
        t = f * DT
        for when, verb in list(todo):
            if isinstance(when, tuple):
                how, a, b = when
                due = state.active[0] >= 0 and (names[state.verb[0]], names[state.into[0]]) == (a, b) and (
                    how == "begun" or state.beta[0] >= 0.5
                )
            else:
                due = t >= when
            if due:
                command(state, 0, verb, stay=True)
                todo.remove((when, verb))
        since = state.arms_since[0]
        rot = frames.step(DT, plant=False)[0][0].copy() if frames is not None else step(state, DT).rotations[0].copy()
        out.append(rot)
        active.append(int(state.active[0]))
        source.append(int(state.verb[0]))
        took.append(bool(state.arms_since[0] < since) - bool(np.isinf(state.arms_since[0]) and since < np.inf))
    assert not todo, f"the plan's commands {todo} were never due"
    return np.array(out), np.array(active), np.array(source), np.array(took), state


def _own_arms(graph, points=None) -> float:
    """The fastest arm joint of the walk and the run each played alone, rad/s (the larger)."""
    arms = _parts(graph)["arms"]
    best = 0.0
    for verb in ("walk", "run"):
        state = new_state(graph, 1, seed=5, start=verb, points=points, stay=True)
        rot = np.array([step(state, DT).rotations[0] for _ in range(150)])
        best = max(best, float(_angular_speed(rot[30:])[:, arms].max()))
    return best


PLAN = [(0.8, "run"), (("mid", "walk", "run"), "walk"), (4.0, "run"), (7.0, "walk")]


def _cosine(graph) -> np.ndarray:
    """:data:`PLAN`'s rotations with the arms blended by the cosine as the legs are (``ARMS_BLEND = 0``:
    no blend is that short)."""
    old = queue.ARMS_BLEND
    try:
        queue.ARMS_BLEND = 0.0
        return _drive(graph, PLAN, 11.0)[0]
    finally:
        queue.ARMS_BLEND = old


def test_walk_and_run_blends_carry_the_arms_on_within_their_verbs_speeds(graphs):
    """Through every blend between the CMU walk and run (one turned back half-way, which takes the offset again
    from the pose shown), no arm joint turns faster than 1.5x the walk's and the run's own fastest; with the arms
    blended by the cosine as the legs are (``ARMS_BLEND = 0``) the same plan turns them at 2.5x and more."""
    graph = graphs["cmu"]
    arms = _parts(graph)["arms"]
    own = _own_arms(graph)
    rot, active, source, took, _ = _drive(graph, PLAN, 11.0)
    turned_back = np.flatnonzero((active[1:] == active[:-1]) & (active[1:] >= 0) & (source[1:] != source[:-1]))
    assert len(turned_back) >= 1, "the plan should turn a blend back"
    assert (took == 1).sum() >= 4 and (took[turned_back + 1] == 1).any(), "each blend between the cycles, and the turn back, take it"
    fastest = _angular_speed(rot)[:, arms].max()
    assert fastest <= 1.5 * own, (np.degrees(fastest), np.degrees(own))
    cosine = _cosine(graph)
    assert _angular_speed(cosine)[:, arms].max() > 2.5 * own


def test_the_offset_moves_only_the_arms_and_is_gone_after_its_time(graphs):
    """Between cycles the legs, hips, trunk and head are the cosine blend's exactly (the feet's timing is the blend's);
    the arms differ only until ``ARMS_BLEND`` after the last blend took their offset, then show the verbs' own pose
    again. (A start carries the whole upper body, ``Graph.carried``: the arms first, then the trunk above the hips,
    the neck and head.)"""
    graph = graphs["cmu"]
    up = graph.arms
    names = graph.skeleton.names
    assert [names[j] for j in up] == ["lclavicle", "lhumerus", "lradius", "lhand", "rclavicle", "rhumerus", "rradius", "rhand"]
    assert [names[j] for j in graph.carried] == [*(names[j] for j in up), "thorax", "head"]
    bandai = graphs["bandai"].skeleton.names
    arms = [bandai[j] for j in graphs["bandai"].arms]
    assert arms == ["Shoulder_L", "UpperArm_L", "LowerArm_L", "Hand_L", "Shoulder_R", "UpperArm_R", "LowerArm_R", "Hand_R"]
    assert [bandai[j] for j in graphs["bandai"].carried] == [*arms, "Spine", "Chest", "Neck", "Head"]
    rest = np.setdiff1d(np.arange(graph.skeleton.num_joints), up)
    rot, _, _, took, _ = _drive(graph, PLAN, 11.0)
    cosine = _cosine(graph)
    np.testing.assert_array_equal(rot[:, rest], cosine[:, rest])
    last = int(np.flatnonzero(took == 1)[-1])
    over = last + int(np.ceil(ARMS_BLEND / DT))  # the frame it was taken at is DT into it
    assert np.abs(rot[last + 1 : over - 1, up] - cosine[last + 1 : over - 1, up]).max() > 0.05
    np.testing.assert_allclose(rot[over:, up], cosine[over:, up], rtol=0, atol=1e-12)


def test_a_blend_cut_short_hands_the_arms_to_the_whole_pose_offset(graphs):
    """Bandai's walk → run cut short half-way by a command to stand (the run plays on alone from the pose shown, whose offset
    then carries the arms' too): its offset ends there, and no arm joint turns faster than 1.5x its verbs'
    own on the readable path or the compiled pass, which agree."""
    graph = graphs["bandai"]
    plan = [(0.6, "run"), (("mid", "walk", "run"), "idle")]
    arms = _parts(graph)["arms"]
    own = _own_arms(graph)
    runs = {compiled: _drive(graph, plan, 6.0, compiled=compiled) for compiled in (False, True)}
    rot, active, source, took, _ = runs[False]
    np.testing.assert_allclose(runs[True][0], rot, rtol=0, atol=1e-9)
    names = graph.verb_names
    taken, ended = np.flatnonzero(took == 1), np.flatnonzero(took == -1)
    assert len(ended) == 1 and taken[0] < ended[0]  # (the way on to the stand, run → walk, takes it again)
    assert (names[source[taken[0]]], names[graph.transitions[active[taken[0]]].target]) == ("walk", "run")
    assert active[ended[0] - 1] == active[taken[0]] and active[ended[0]] < 0  # the walk → run, cut short
    assert _angular_speed(rot)[:, arms].max() <= 1.5 * own


def test_the_compiled_pass_carries_the_arms_as_the_reference_does(graphs):
    """The CMU plan (taken four times and turned back once) on the compiled pass: the same rotations, to 1e-9."""
    graph = graphs["cmu"]
    ref, *_, ref_state = _drive(graph, PLAN, 11.0)
    fast, *_, fast_state = _drive(graph, PLAN, 11.0, compiled=True)
    np.testing.assert_allclose(fast, ref, rtol=0, atol=1e-9)
    np.testing.assert_allclose(fast_state.arms_rot, ref_state.arms_rot, rtol=0, atol=1e-9)


def test_a_stop_turned_back_and_over_within_a_frame_takes_the_arms_again_against_the_walk(graphs):
    """A walk asked for the frame a stop began turns it back, and the turned-back blend is over within the next frame:
    the walk plays alone. The arms' offset the stop took against the stand's arms is taken again against the walk's
    (shown on the walk's, it threw an arm at 3.5-11x the walk's own; ``test_edges``), after a run → walk whose own
    offset is still fading; the compiled pass does the same, to 1e-9."""
    graph = graphs["bandai"]
    plan = [(0.5, "run"), (2.0, "walk"), (3.0, "idle"), (("begun", "walk", "idle"), "walk")]
    rot, active, source, took, state = _drive(graph, plan, 6.0)
    stop = int(np.flatnonzero(graph.carries_arms == 2)[0])
    first = int(np.flatnonzero(active == stop)[0])
    assert took[first] == 1 and active[first + 1] < 0, (took[first - 1 : first + 3], active[first - 1 : first + 3])
    assert source[first + 1] == graph.verb_index("walk")
    arms = _parts(graph)["arms"]
    assert _angular_speed(rot[first - 2 : first + 15])[:, arms].max() <= 1.5 * _own_arms(graph)
    fast, *_, fast_state = _drive(graph, plan, 6.0, compiled=True)
    np.testing.assert_allclose(fast, rot, rtol=0, atol=1e-9)
    np.testing.assert_allclose(fast_state.arms_rot, state.arms_rot, rtol=0, atol=1e-9)


def test_a_stop_carries_the_arms_over_its_blend_and_no_further(graphs):
    """A stop (the walk into the stand) carries the arms over its own blend: its arms turn no faster than with the
    cosine (which swung them on with the walk's weight while drawing them to the stand's: 1.63x the walk's own in
    the fixed script's stop, ``test_transitions``), and from the blend's end the pose is the stand's own again."""
    graph = graphs["bandai"]
    arms = _parts(graph)["arms"]
    plan = [(1.2, "idle")]
    rot, active, _, took, _ = _drive(graph, plan, 4.0)
    cosine = load_graph(GRAPHS / "bandai.toml")
    carries = cosine.carries_arms.copy()
    assert (carries == 2).sum() == 1  # the stop (walk → idle), the graph's one cosine blend from a cycle into a one-shot
    carries[carries == 2] = 0
    cosine.__dict__["carries_arms"] = carries
    plain, active_plain, *_ = _drive(cosine, plan, 4.0)
    np.testing.assert_array_equal(active, active_plain)
    stop = np.flatnonzero(active == int(np.flatnonzero(graph.carries_arms == 2)[0]))
    assert took[stop[0]] == 1 and stop[-1] - stop[0] > 10
    inside = slice(stop[0], stop[-1] + 1)
    assert np.abs(rot[inside] - plain[inside]).max() > 0.05
    np.testing.assert_allclose(rot[stop[-1] + 1 :], plain[stop[-1] + 1 :], rtol=0, atol=1e-12)
    assert _angular_speed(rot[stop[0] - 1 : stop[-1] + 2])[:, arms].max() < _angular_speed(plain[stop[0] - 1 : stop[-1] + 2])[:, arms].max()
