"""The frame as one compiled pass (:mod:`adverbs.runtime.frame`) against the readable reference path
(:func:`adverbs.graph.player.step` then :func:`~adverbs.graph.planted.plant`): the same frames, the same log, on the
shipped graphs and the demo script; the same frames whatever the number of threads."""

from __future__ import annotations

import multiprocessing
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import on_their_feet

from adverbs import AdverbsError, load_graph
from adverbs.errors import AdverbsWarning
from adverbs.graph.planted import planter
from adverbs.graph.player import step
from adverbs.graph.queue import command
from adverbs.graph.state import new_state
from adverbs.runtime import Simulation
from adverbs.runtime.frame import FramePass, Threads
from adverbs.runtime.script import load_script

ROOT = Path(__file__).resolve().parent.parent
ATOL = 1e-9  # metres and quaternion components: "equal to today's" (the two differ by rounding, ~1e-13)


@pytest.fixture(scope="module")
def graphs():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        return {name: load_graph(ROOT / "graphs" / f"{name}.toml") for name in ("bandai", "cmu")}


def _scenario(graph, compiled: bool, creatures: int = 12, seconds: float = 60.0, seed: int = 3) -> Simulation:
    """``creatures`` creatures told, at seeded random times, to perform any verb of the graph (often mid-transition,
    so blends are interrupted and turned back) and to change their adverbs, eased or at once."""
    rng = np.random.default_rng(seed)
    sim = Simulation(graph, fps=30.0, seed=seed, compiled=compiled)
    lo, hi = graph.adverb_range(0.0)  # the examples' own span
    crowd = [sim.add_creature(at=(2.0 * k, 0.0), heading=float(rng.uniform(0, 360))) for k in range(creatures)]
    for c in crowd:
        for t in np.sort(rng.uniform(0.2, seconds, int(seconds / 2.5))):
            c.perform(str(rng.choice(graph.verb_names)), at=float(t), stay=bool(rng.random() < 0.7))
        for t in np.sort(rng.uniform(0.2, seconds, int(seconds / 6))):
            a = int(rng.integers(len(graph.adverb_names)))
            value = float(rng.uniform(lo[a], hi[a]))
            c.set_adverbs({graph.adverb_names[a]: value}, at=float(t), over=float(rng.choice([0.0, 0.5, 1.5])))
    sim.run(seconds)
    return sim


def _recorded(sim: Simulation) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Every group's recorded rotations and translations ``(F, C, J, ·)`` and the planter's modes ``(F, C, L)``."""
    out = []
    for g in sim._groups.values():
        poses = [g.spool.creature(i) for i in range(g.size)]
        modes = [g.spool.held(i)[0] for i in range(g.size)]
        out.append((np.stack([r for r, _ in poses], 1), np.stack([t for _, t in poses], 1), np.stack(modes, 1)))
    return out


def _assert_same(a: Simulation, b: Simulation) -> None:
    assert a.frames == b.frames
    for (ra, ta, ma), (rb, tb, mb) in zip(_recorded(a), _recorded(b)):
        np.testing.assert_allclose(rb, ra, rtol=0, atol=ATOL)
        np.testing.assert_allclose(tb, ta, rtol=0, atol=ATOL)
        np.testing.assert_array_equal(mb, ma)
    assert b.log == a.log  # every command, refusal and transition, at the same times


@pytest.mark.parametrize("name", ["bandai", "cmu"])
def test_compiled_frames_equal_the_reference_over_a_minute_of_twelve_creatures(graphs, name):
    graph = graphs[name]
    reference = _scenario(graph, compiled=False)
    compiled = _scenario(graph, compiled=True)
    assert all(g.frame is not None for g in compiled._groups.values())  # the compiled pass ran
    assert all(g.frame is None for g in reference._groups.values())
    _assert_same(reference, compiled)
    kinds = {e["command"] for e in compiled.log}
    assert {"transition", "perform", "adverbs"} <= kinds  # the run took transitions and changed adverbs
    transitions = [e for e in compiled.log if e["command"] == "transition"]
    assert len({(e["from"], e["to"]) for e in transitions}) >= min(5, len(graph.transitions))  # of several kinds
    # The arms carried past walk ↔ run blends (player._arms), in both.
    assert all((g.state.arms_of >= 0).any() for g in (*compiled._groups.values(), *reference._groups.values()))


def test_compiled_frames_equal_the_reference_on_the_demo_script(graphs):
    script = load_script(ROOT / "scripts" / "demo.toml")
    runs = []
    for compiled in (False, True):
        sim = Simulation(list(graphs.values()), fps=script.fps, seed=script.seed, compiled=compiled)
        script.apply(sim)
        sim.run(script.seconds)
        runs.append(sim)
    _assert_same(*runs)


def test_one_thread_and_two_give_the_same_frames_bit_for_bit(graphs):
    graph = graphs["bandai"]
    n = 80  # enough for two threads to split them (Threads runs fewer on one)
    frames = []
    for threads in (1, 2):
        rng = np.random.default_rng(5)
        state = new_state(graph, n, 7, "walk", root=np.c_[rng.uniform(0, 50, n), rng.uniform(0, 50, n), rng.uniform(0, 6, n)])
        feet = planter(graph, n)
        fp = FramePass(state, feet, threads=threads)
        out = []
        for f in range(90):
            if f % 20 == 10:
                for c in range(0, n, 3):
                    command(state, c, str(rng.choice(graph.verb_names)))
            rot, trans = fp.step(1 / 30)
            out.append((rot.copy(), trans.copy(), feet.mode.copy()))
        frames.append(out)
    for (r1, t1, m1), (r2, t2, m2) in zip(*frames):
        assert np.array_equal(r1, r2) and np.array_equal(t1, t2) and np.array_equal(m1, m2)


def test_threads_split_every_creature_once():
    seen = []
    Threads(2).run(lambda lo, hi, tag: seen.append((lo, hi, tag)) or True, 1000, ("x",))
    assert sorted(seen) == [(0, 500, "x"), (500, 1000, "x")]
    seen.clear()
    Threads(2).run(lambda lo, hi: seen.append((lo, hi)) or True, 5, ())  # too few to share: one range
    assert seen == [(0, 5)]
    with pytest.raises(AdverbsError, match="threads"):
        Threads(0)


_SHARED = Threads(2)  # made in the parent: a forked child inherits it, without its threads


def _ranges(creatures: int) -> list:
    seen = []
    _SHARED.run(lambda lo, hi: seen.append((lo, hi)) or True, creatures, ())
    return sorted(seen)


def test_a_forked_process_runs_the_pass_on_threads_of_its_own():
    # A Dask or multiprocessing worker forked after the pass ran on two threads has none of the parent's threads;
    # handing them a range would wait forever. The child makes its own.
    here = _ranges(1000)
    with multiprocessing.get_context("fork").Pool(1) as pool:
        there = pool.apply_async(_ranges, (1000,)).get(timeout=60)
    assert there == here == [(0, 500), (500, 1000)]


def test_a_bad_step_is_refused_and_changes_nothing(graphs):
    state = new_state(graphs["cmu"], 2)
    fp = FramePass(state, planter(graphs["cmu"], 2))
    fp.step(1 / 30)
    g = state.g.copy()
    for dt in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(AdverbsError, match="dt"):
            fp.step(dt)
    np.testing.assert_array_equal(state.g, g)


def test_planting_switched_off_and_on_again_plants_with_the_new_planter(graphs):
    """``Simulation.plant`` starts the planter afresh when switched back on: the pass plants with that one too."""
    runs = []
    for compiled in (False, True):
        sim = Simulation(graphs["cmu"], fps=30.0, seed=1, compiled=compiled)
        for k in range(2):
            sim.add_creature(at=(2.0 * k, 0.0)).perform("run", at=0.5 + k)
        sim.set_plant(False, at=2.0)
        sim.set_plant(True, at=3.0)
        sim.run(6.0)
        runs.append(sim)
    _assert_same(*runs)
    g = next(iter(runs[1]._groups.values()))
    assert g.frame.feet is g.feet


def test_caches_brought_to_other_points_between_frames_are_brought_back(graphs):
    """A command's own transition (an inertial start, in Python between frames) brings the verbs' caches to the
    adverbs of that moment; changed back before the next frame, the pass must not keep those rows."""
    runs = []
    for compiled in (False, True):
        sim = Simulation(graphs["bandai"], fps=30.0, seed=0, compiled=compiled)
        c = sim.add_creature(verb="reach")
        c.set_adverbs({"valence": 0.9}, over=0.0, at=1.71)
        c.perform("walk", at=1.715)
        c.set_adverbs({"valence": 0.0}, over=0.0, at=1.72)
        sim.run(4.0)
        runs.append(sim)
    _assert_same(*runs)


def test_a_verb_no_creature_plays_may_refuse_their_adverbs(graphs):
    """Far adverbs that only an unplayed verb refuses (the run, at run_speed=100, while every creature walks) stop
    neither path: the pass leaves that verb's rows until a creature plays it, as the reference does."""
    graph = graphs["cmu"]
    p = graph.defaults.copy()
    p[graph.adverb_names.index("run_speed")] = 100.0
    reference, compiled = (new_state(graph, 2, 0, "walk", points=p, stay=True) for _ in range(2))
    fp = FramePass(compiled)
    for _ in range(30):
        plant_ref = step(reference, 1 / 30)
        rot, trans = fp.step(1 / 30, plant=False)
        np.testing.assert_allclose(rot, plant_ref.rotations, rtol=0, atol=ATOL)
        np.testing.assert_allclose(trans, plant_ref.translations, rtol=0, atol=ATOL)


def test_compiled_frames_equal_the_reference_where_the_stand_and_gestures_stand_on_their_feet(tmp_path):
    """The Bandai graph with its stand and gestures standing on their feet (``in_place = "feet"``: the hips' sway over
    the feet is the pose's, blends between them paced by it too): a run of six creatures through every verb, the
    compiled frames the reference's."""
    feet = [f"bandai_{name}" for name in ("idle", "bow", "bye", "guide")]
    on_their_feet(tmp_path, feet, [f"bandai_{name}" for name in ("styled_walk", "run", "reach")])
    (tmp_path / "graphs").mkdir()
    (tmp_path / "graphs" / "bandai.toml").write_text((ROOT / "graphs" / "bandai.toml").read_text())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        graph = load_graph(tmp_path / "graphs" / "bandai.toml")
    anchored = {n for n, v in zip(graph.verb_names, graph.verbs) if v.encoding.anchored}
    assert anchored == {"idle", "bow", "bye", "guide"}, anchored
    runs = [_scenario(graph, compiled=c, creatures=6, seconds=30.0, seed=5) for c in (False, True)]
    _assert_same(*runs)
    stands = {(e["from"], e["to"]) for e in runs[1].log if e["command"] == "transition"}
    assert len({s for s in stands if set(s) <= anchored and s[0] != s[1]}) >= 3, stands  # paced by the hips too
