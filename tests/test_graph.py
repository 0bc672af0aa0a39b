"""Verb graphs (§5): the blend's laws, the planner, the draws, spec errors, and transitions on real capture."""

from __future__ import annotations

import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import chisquare

from adverbs.errors import AdverbsError, AdverbsWarning
from adverbs.graph import (
    CommandRefused,
    Cue,
    Graph,
    GraphSpecError,
    Transition,
    blend_weight,
    command,
    load_graph,
    new_state,
    perform,
    plant,
    planter,
    step,
)
from adverbs.graph._time_kernel import hold_rows
from adverbs.graph.clocks import clock_of, generic_of
from adverbs.graph.player import _velocity
from adverbs.interp import timewarp
from adverbs.kinematics import quat
from adverbs.motion.clip import Clip
from adverbs.motion._pose_kernel import blend_poses
from adverbs.motion.encoding import advance_root
from adverbs.feet.measures import measure_feet, planted_drift
from adverbs.feet.planter import BALL, effector_joints, hold_modes, swing_lifts
from adverbs.verb.store import save_verb

GRAPHS = Path(__file__).resolve().parent.parent / "graphs"
DT = 1.0 / 30.0


def _load(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        return load_graph(GRAPHS / f"{name}.toml")


@pytest.fixture(scope="module")
def cmu():
    return _load("cmu")


@pytest.fixture(scope="module")
def bandai():
    return _load("bandai")


# ----- the blend's laws --------------------------------------------------------------------------


def test_blend_weight_is_the_cosine_law():
    beta = np.array([0.0, 0.25, 0.5, 0.75, 1.0])
    np.testing.assert_allclose(blend_weight(beta), [1.0, 0.5 + 0.5 * np.sqrt(0.5), 0.5, 0.5 - 0.5 * np.sqrt(0.5), 0.0], rtol=0, atol=1e-15)
    b = np.linspace(0, 1, 101)
    np.testing.assert_allclose(blend_weight(b), 0.5 * np.cos(b * np.pi) + 0.5, rtol=0, atol=1e-15)


POINTS = [
    {"walk_speed": 1.3, "run_speed": 3.0, "turn": 0.0},
    {"walk_speed": 1.0, "run_speed": 2.4, "turn": 40.0},
    {"walk_speed": 1.7, "run_speed": 3.8, "turn": -30.0},
]


def _into(graph, source, target, point, frames_in=0):
    """A creature playing ``source`` with the transition to ``target`` next, stepped until it is ``frames_in`` frames in."""
    k = graph.path(source, target)[0]
    state = new_state(graph, 1, seed=0, start=source, points=graph.point(point)[None])
    state.queue[0] = [k]
    frames = []
    while state.active[0] != k:
        frames.append(step(state, DT))
    for _ in range(frames_in):
        frames.append(step(state, DT))
    return state, k, frames


@pytest.mark.parametrize("point", POINTS, ids=["centre", "slow-left", "fast-right"])
@pytest.mark.parametrize("pair", [("walk", "run"), ("run", "walk")])
def test_duration_is_the_mean_of_the_regions_clock_lengths(cmu, pair, point):
    state, k, _ = _into(cmu, *pair, point)
    t = cmu.transitions[k]
    lengths = []
    for v, region in ((t.source, t.source_region), (t.target, t.target_region)):
        verb = cmu.verbs[v]
        keys = verb.keytimes(verb.point({a: point[n] for a, n in zip(verb.adverb_names, [cmu.adverb_names[c] for c in cmu.columns[v]])}))
        ends = timewarp.clock_time(np.array(region), keys, verb.generic_keytimes)
        lengths.append(ends[1] - ends[0])
    assert state.length[0] == pytest.approx(0.5 * (lengths[0] + lengths[1]), rel=1e-12)
    # β runs linearly: one frame later it has moved on by dt / duration.
    before = state.beta[0]
    step(state, DT)
    assert state.beta[0] - before == pytest.approx(DT / state.length[0], rel=1e-12)


def test_every_joint_is_the_cosine_blend_of_the_two_verbs(cmu):
    """Mid-transition, each joint's rotation is slerp(B, A, α) of the two verbs' own poses at their generic times."""
    point = POINTS[1]
    state, k, _ = _into(cmu, "walk", "run", point, frames_in=3)
    frame = step(state, DT)
    alpha = blend_weight(state.beta[0])
    assert 0.05 < alpha < 0.95
    poses = []
    for v, g in ((state.verb[0], state.g[0]), (state.into[0], state.g_into[0])):
        verb = cmu.verbs[v]
        p = cmu.verb_points(v, state.points)[0]
        dofs = verb.dofs(p[None], np.array([g]))
        poses.append(verb.encoding.decode_pose(dofs[0], frame.root[0])[0])
    body = cmu.verbs[0].encoding.body_root
    below = [j for j in range(cmu.skeleton.num_joints) if j != body and body in cmu.skeleton.ancestors(j)]
    want = quat.slerp(poses[1][below], poses[0][below], np.full(len(below), alpha))
    got = frame.rotations[0, below]
    np.testing.assert_allclose(np.abs(np.sum(want * got, axis=-1)), 1.0, rtol=0, atol=1e-12)


# ----- the planner and the draws -------------------------------------------------------------------


def _chain(cmu, names, edges, likelihoods=None):
    walk = cmu.verbs[0]
    verbs = [replace(walk, name=n) for n in names]
    ts = [
        Transition(names.index(a), names.index(b), (0.0, 0.25), (0.0, 0.25), (likelihoods or {}).get((a, b), 1.0))
        for a, b in edges
    ]
    return Graph.make("test", verbs, ts)


def test_paths_are_shortest_on_a_graph_with_a_known_answer(cmu):
    g = _chain(cmu, list("abcdef"), [("a", "b"), ("b", "c"), ("c", "d"), ("a", "e"), ("e", "d"), ("d", "a"), ("f", "a")])
    route = [(g.verb_names[g.transitions[k].source], g.verb_names[g.transitions[k].target]) for k in g.path("a", "d")]
    assert route == [("a", "e"), ("e", "d")]  # two transitions, not a → b → c → d
    route = [(g.verb_names[g.transitions[k].source], g.verb_names[g.transitions[k].target]) for k in g.path("b", "e")]
    assert route == [("b", "c"), ("c", "d"), ("d", "a"), ("a", "e")]
    assert g.path("c", "c") == []
    with pytest.raises(CommandRefused, match="'f' cannot be reached from 'a'"):
        g.path("a", "f")
    with pytest.raises(CommandRefused, match="no verb 'fly'; its verbs are a, b, c"):
        g.path("a", "fly")


def test_default_draws_follow_the_likelihoods(cmu):
    likelihoods = {("a", "b"): 1.0, ("a", "c"): 2.0, ("a", "d"): 5.0}
    g = _chain(cmu, list("abcd"), [("a", "b"), ("a", "c"), ("a", "d"), ("b", "a"), ("c", "a"), ("d", "a")], likelihoods)
    ways = g.leaving(0)  # b, c, d, and the loop the graph adds (likelihood 1)
    weights = np.array([g.transitions[k].likelihood for k in ways])
    np.testing.assert_array_equal(weights, [1.0, 2.0, 5.0, 1.0])
    rng = np.random.default_rng(7)
    n = 6000
    counts = np.bincount([ways.index(g.draw(0, rng)) for _ in range(n)], minlength=len(ways))
    assert chisquare(counts, n * weights / weights.sum()).pvalue > 1e-3
    # The creatures' own queues draw the same way, each from its own seeded generator.
    state = new_state(g, 3000, seed=11, start="a")
    counts = np.bincount([ways.index(q[0]) for q in state.queue], minlength=len(ways))
    assert chisquare(counts, 3000 * weights / weights.sum()).pvalue > 1e-3
    again = new_state(g, 3000, seed=11, start="a")
    assert [q[0] for q in again.queue] == [q[0] for q in state.queue]
    # draw finds one uniform number in the cumulative odds itself: the same draws as numpy's choice by probabilities
    # (what it called until session 54), number for number, leaving each generator where choice leaves it.
    for seed in range(200):
        mine, numpy_s = np.random.default_rng(seed), np.random.default_rng(seed)
        drawn = [g.draw(0, mine) for _ in range(25)]
        assert drawn == [ways[int(numpy_s.choice(len(ways), p=weights / weights.sum()))] for _ in range(25)]
        assert mine.random() == numpy_s.random()


def test_a_refused_command_changes_nothing_and_the_creature_moves_on(cmu):
    state = new_state(cmu, 1, seed=0)
    for _ in range(5):
        step(state, DT)
    queue, root = list(state.queue[0]), state.root.copy()
    with pytest.raises(CommandRefused, match="no verb 'fly'"):
        command(state, 0, "fly")
    assert state.queue[0] == queue and state.goal[0] == -1
    frame = step(state, DT)
    assert np.all(np.isfinite(frame.rotations)) and np.linalg.norm(frame.root[0, :2] - root[0, :2]) > 0.01


# ----- graph specs --------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def built(tmp_path_factory, cmu, bandai):
    d = tmp_path_factory.mktemp("verbs")
    for g, names in ((cmu, ["walk", "run"]), (bandai, ["idle", "bow"])):
        for n in names:
            save_verb(g.verbs[g.verb_index(n)], d / f"{n}.verb")
    return d


def _graph_file(tmp_path, built, verbs, transitions):
    text = "".join(f'[[verbs]]\nname = "{n}"\nverb = "{built / (n + ".verb")}"\n\n' for n in verbs)
    for t in transitions:
        text += "[[transitions]]\n" + "".join(f"{k} = {v}\n" for k, v in t.items()) + "\n"
    path = tmp_path / "graph.toml"
    path.write_text(text)
    return path


GOOD = {"from": '"walk"', "to": '"run"', "from_region": "[0.0, 0.25]", "to_region": "[0.0, 0.25]"}


@pytest.mark.parametrize(
    "change, field, reason",
    [
        ({"to": '"swim"'}, "transitions[1].to", "unknown verb 'swim'; the graph's verbs are walk, run"),
        ({"from_region": "[0.5, 1.2]"}, "transitions[1].from_region", "must lie in generic time [0, 1]"),
        ({"to_region": "[0.3, 0.3]"}, "transitions[1].to_region", "is empty"),
        ({"likelihood": "0"}, "transitions[1].likelihood", "likelihood must be a positive number"),
        ({"blend": '"crossfade"'}, "transitions[1].blend", "must be one of cosine, inertial"),
        ({"speed": "2"}, "transitions[1].speed", "unknown field"),
    ],
)
def test_graph_spec_mistakes_name_the_file_and_field(tmp_path, built, change, field, reason):
    path = _graph_file(tmp_path, built, ["walk", "run"], [{**GOOD, **change}])
    with pytest.raises(GraphSpecError) as info:
        load_graph(path)
    assert info.value.path == str(path) and info.value.field == field
    assert reason in str(info.value) and str(path) in str(info.value)


def test_graph_spec_refuses_other_skeletons_and_dead_ends(tmp_path, built):
    path = _graph_file(tmp_path, built, ["walk", "idle"], [])
    with pytest.raises(GraphSpecError, match=r"verbs\[2\]\.verb.*'idle' is on a different skeleton from verb 'walk': it has 22 joints"):
        load_graph(path)
    path = _graph_file(tmp_path, built, ["idle", "bow"], [{"from": '"idle"', "to": '"bow"', "from_region": "[0.5, 1.0]", "to_region": "[0.0, 0.1]"}])
    with pytest.raises(GraphSpecError, match="verb 'bandai-bow' has no way out|verb 'bow' has no way out"):
        load_graph(path)
    with pytest.raises(GraphSpecError, match="no such graph file"):
        load_graph(tmp_path / "missing.toml")


# ----- transitions on real capture -------------------------------------------------------------------


def _angular_speed(rotations):
    """Largest joint angular speed per frame gap, ``(F − 1,)`` rad/s, of local rotations ``(F, J, 4)``."""
    rel = quat.mul(quat.inv(rotations[:-1]), rotations[1:])
    rel = np.where(rel[..., 3:] < 0.0, -rel, rel)
    return np.linalg.norm(quat.log(rel), axis=-1).max(axis=-1) / DT


def _own_speed(graph, v, point):
    """The verb's own largest joint angular speed at ``point`` over one cycle (or its whole motion)."""
    verb = graph.verbs[v]
    p = graph.verb_points(v, graph.point(point)[None])[0]
    clip, _ = verb.synthesize(p, cycles=2 if verb.cyclic else None, fps=30)
    return _angular_speed(clip.rotations).max()


def _own_sway(graph, v, point):
    """How fast an anchored verb (standing on its feet: ``in_place = "feet"``) moves its hips over them at ``point``,
    at its fastest (m/s; its root does not travel)."""
    verb = graph.verbs[v]
    clip, _ = verb.synthesize(graph.verb_points(v, graph.point(point)[None])[0], fps=30)
    hips = clip.global_positions()[:, verb.encoding.body_root][:, [0, 2]]
    return float(np.linalg.norm(np.diff(hips, axis=0), axis=-1).max() * 30)


def _points(graph, t):
    """Three graph adverb points for transition ``t``: the defaults, and every adverb the two verbs take at the
    first and third quartiles of their examples."""
    out = [dict(zip(graph.adverb_names, graph.defaults))]
    for q in (0.25, 0.75):
        p = dict(out[0])
        for v in (t.source, t.target):
            verb = graph.verbs[v]
            for i, c in enumerate(graph.columns[v]):
                p[graph.adverb_names[c]] = float(np.quantile(verb.points[:, i], q))
        out.append(p)
    return out


def _run(graph, k, point, interrupt=False):
    """Play transition ``k`` at ``point`` (interrupted halfway, back to its source, when asked): frames, planted
    clip, report, the frames of the window measured, and the verbs involved."""
    t = graph.transitions[k]
    state = new_state(graph, 1, seed=0, start=t.source, points=graph.point(point)[None])
    source = graph.verbs[t.source]
    lead = t.source_region[0] - 0.15
    state.g[0] = lead % 1.0 if source.cyclic else max(lead, 0.0)
    if t.source == t.target:
        state.queue[0] = [k]
    else:  # the planner's path, a loop first when the region has gone by in this cycle
        command(state, 0, graph.verb_names[t.target])
        assert k in state.queue[0]
    feet = planter(graph, 1)
    rot, trans, free, modes, window, involved = [], [], [], [], [], {t.source, t.target}
    done, ended = None, False
    for f in range(2000):
        frame = step(state, DT)
        r, tr, _ = plant(feet, frame, DT, state.alone, state.standing)
        rot.append(r[0]), trans.append(tr[0]), free.append(frame), modes.append(feet.mode[0] == BALL)
        if (state.active[0] == k and not ended) or (done is not None and f < done):
            window.append(f)
            involved |= {int(state.verb[0])} | ({int(state.into[0])} if state.active[0] >= 0 else set())
        ended |= bool(window) and state.active[0] != k
        if interrupt and state.active[0] == k and state.beta[0] >= 0.5 and done is None:
            command(state, 0, graph.verb_names[t.source])
            done = f + 45
        if window and f > window[-1] + 15 and (not interrupt or done is not None and f > done):
            break
    assert window, "the transition never started"
    clip = Clip(graph.skeleton, np.array(rot), np.array(trans), 30.0)
    return free, clip, np.array(window), involved, np.array(modes)


@pytest.mark.parametrize("name", ["cmu", "bandai"])
@pytest.mark.parametrize("interrupt", [False, True], ids=["whole", "interrupted"])
def test_every_transition_is_continuous_smooth_and_keeps_its_feet(name, interrupt, cmu, bandai):
    graph = {"cmu": cmu, "bandai": bandai}[name]
    body = graph.verbs[0].encoding.body_root
    tips = effector_joints(next(v for v in graph.verbs if v.holds))
    failures = []
    for k, t in enumerate(graph.transitions):
        if interrupt and not t.interruptible:
            continue
        for point in _points(graph, t):
            free, clip, window, involved, planted = _run(graph, k, point, interrupt)
            what = f"{graph.verb_names[t.source]} → {graph.verb_names[t.target]} at {point}"
            # The body's path is continuous: no step longer than 1.5 × the speed its root moves at and the hips sway
            # over the feet in the verbs that stand on them (their own fastest; nothing for the rest), and 1 mm.
            hips = clip.global_positions()[:, body][:, [0, 2]]
            steps = np.linalg.norm(np.diff(hips, axis=0), axis=-1)[window[window > 0] - 1]
            speed = np.array([np.hypot(*free[f].velocity[0, :2]) for f in window[window > 0]])
            prev = np.array([np.hypot(*free[f - 1].velocity[0, :2]) for f in window[window > 0]])
            sway = max([_own_sway(graph, v, point) for v in involved if graph.verbs[v].encoding.anchored] or [0.0])
            if np.any(steps > 1.5 * (np.maximum(speed, prev) + sway) * DT + 1e-3):
                failures.append(f"{what}: a body step of {steps.max() * 1000:.1f} mm (sway {sway * DT * 1000:.1f})")
            # Joints turn no faster than 1.5 × the faster verb's own fastest.
            rotations = np.array([f.rotations[0] for f in free])
            fastest = _angular_speed(rotations)[window[window > 0] - 1].max()
            own = max(_own_speed(graph, v, point) for v in involved)
            if fastest > 1.5 * own:
                failures.append(f"{what}: joints at {fastest:.1f} rad/s, the verbs' own fastest {own:.1f}")
            # Planted toes stay put (1 cm) and never go below the floor (5 mm, the planting tests' bound).
            toes = clip.global_positions()[:, tips]
            for i in range(len(tips)):
                spans = [(a, b) for a, b in _runs(planted[:, i]) if b > window[0] and a <= window[-1]]
                drift = planted_drift(toes[:, i], spans)
                if len(drift) and drift.max() > 0.01:
                    failures.append(f"{what}: toe {graph.skeleton.names[tips[i]]} drifts {drift.max() * 1000:.1f} mm while held")
            verb = next(v for v in graph.verbs if v.holds)
            heights = np.array([h.height for h in verb.holds])
            low = (toes[window, :, 1] - heights).min()
            if low < -0.005:
                failures.append(f"{what}: a toe {-low * 1000:.1f} mm below the floor")
    assert not failures, "\n".join(failures)


def _runs(mask):
    from adverbs.motion.contacts import runs

    return runs(np.asarray(mask))


# ----- circles, and a long random walk ---------------------------------------------------------------


@pytest.mark.parametrize("speed, turn", [(1.3, 30.0), (1.0, -45.0), (1.2, 60.0)])
def test_a_walk_with_a_constant_turn_traces_its_circle(cmu, speed, turn):
    walk = cmu.verbs[cmu.verb_index("walk")]
    g = Graph.make("walk", [walk], [])  # the walk and its own loop
    perf = perform(g, [], seconds=20.0, adverbs={"walk_speed": speed, "turn": turn})
    xz = perf.free.global_positions()[30:, walk.encoding.body_root][:, [0, 2]]
    a = np.c_[2 * xz, np.ones(len(xz))]
    (cx, cz, c), *_ = np.linalg.lstsq(a, np.sum(xz**2, axis=1), rcond=None)
    radius = np.sqrt(c + cx**2 + cz**2)
    asked = speed / np.radians(abs(turn))
    assert abs(radius / asked - 1.0) <= 0.05, (radius, asked)
    # It goes round, not back and forth: the heading turns the way the adverb says, loop after loop.
    assert np.sign(perf.state.root[0, 2]) == np.sign(turn) and abs(perf.state.root[0, 2]) > np.radians(abs(turn)) * 15


def test_ten_minutes_of_random_commands_through_the_bandai_graph(bandai):
    """A seeded 10-minute random walk: finite, rigid, feet on the floor, reproducible; latency reported."""
    rng = np.random.default_rng(2026)
    times = np.cumsum(rng.uniform(2.0, 8.0, 200))
    cues = [Cue(float(t), str(rng.choice(bandai.verb_names))) for t in times[times < 590.0]]
    for t in rng.uniform(0, 590, 40):  # and moods changing
        cues.append(Cue(float(t), adverbs={"valence": float(rng.uniform(-1, 1)), "energy": float(rng.uniform(-1, 1))}))
    perf = perform(bandai, cues, seconds=600.0, seed=5)
    pos = perf.planted.global_positions()
    assert np.all(np.isfinite(pos)) and np.all(np.isfinite(perf.planted.rotations))
    skel, enc = bandai.skeleton, bandai.verbs[0].encoding
    moving = {enc.body_root, *(int(j) for v in bandai.verbs for j in v.encoding.translated)}  # joints that translate
    bones = np.array([j for j in range(skel.num_joints) if skel.parents[j] >= 0 and j not in moving])
    lengths = np.linalg.norm(pos[:, bones] - pos[:, skel.parents[bones]], axis=-1)
    np.testing.assert_allclose(lengths, np.broadcast_to(np.linalg.norm(skel.offsets[bones], axis=-1), lengths.shape), rtol=0, atol=1e-6)
    verb = next(v for v in bandai.verbs if v.holds)
    metrics = measure_feet(verb, perf.planted, perf.report, None, perf.free)
    assert metrics.lowest >= -0.005, metrics.line()
    assert np.median(metrics.toe_drift) <= 0.001 and metrics.toe_drift.max() <= 0.01, metrics.line()
    played = {bandai.verb_names[v] for v in perf.verb}
    assert played == set(bandai.verb_names), played
    latency = np.array([x for _, _, x in perf.state.latencies])
    assert len(latency) > 50 and np.all(latency >= 0) and np.all(np.isfinite(latency))
    print(f"\ncommand latency over {len(latency)} commands: median {np.median(latency):.2f} s, 95th percentile {np.percentile(latency, 95):.2f} s")
    # The same seed, the same motion: the first minute again, frame for frame.
    again = perform(bandai, [c for c in cues if c.time < 60.0], seconds=60.0, seed=5)
    np.testing.assert_array_equal(again.planted.rotations, perf.planted.rotations[:1800])
    np.testing.assert_array_equal(again.planted.translations, perf.planted.translations[:1800])


def test_a_bad_adverb_in_a_script_is_refused_and_the_creature_carries_on(cmu):
    perf = perform(cmu, [Cue(0.5, "swim"), Cue(1.0, adverbs={"turn": float("nan")}), Cue(1.5, adverbs={"colour": 1.0})], seconds=3.0)
    assert [t for t, _ in perf.refused] == [0.5, 1.0, 1.5]
    assert "no verb 'swim'" in perf.refused[0][1] and "'turn' must be a finite number" in perf.refused[1][1]
    assert "no adverb 'colour'" in perf.refused[2][1]
    assert np.all(np.isfinite(perf.planted.rotations)) and perf.planted.num_frames == 90


@pytest.mark.parametrize("value", [1e4, -1e4, 1e300])
def test_an_adverb_far_outside_the_graph_is_refused_before_it_plays(cmu, value):
    """Every adverb, far past the examples: refused up front, or as a cue (recorded, the point kept, the creature
    moving on). Unchecked, ``run_speed=1e4`` divided by zero in the player and ``run_speed=100`` put toes 47 mm
    through the floor."""
    for name in cmu.adverb_names:
        with pytest.raises(AdverbsError, match=f"{name}=.* is out of range: graph 'cmu' plays {name} from"):
            perform(cmu, seconds=1.0, adverbs={name: value})
        perf = perform(cmu, [Cue(0.2, "run" if "run" in name else "walk"), Cue(0.5, adverbs={name: value})], seconds=2.0)
        assert [t for t, _ in perf.refused] == [0.5] and "out of range" in perf.refused[0][1]
        np.testing.assert_array_equal(perf.state.points[0], cmu.point())
        assert np.all(np.isfinite(perf.planted.translations)) and perf.planted.num_frames == 60


def test_graph_adverbs_must_be_finite(cmu):
    with pytest.raises(AdverbsError, match="'turn' must be a finite number"):
        new_state(cmu, 1, points=np.array([[1.3, np.nan, 3.0]]))


@pytest.mark.parametrize("valence, energy, turn", [(0.0, 0.0, 0.0), (0.5, 0.0, 30.0), (1.0, 0.6, 0.0), (-0.5, -0.5, -20.0)])
def test_stopping_does_not_drag_the_swinging_foot(bandai, valence, energy, turn):
    """Walk → stand: a foot let go in the blend lifts before it travels: each release there travels at most 1 cm
    before it is 2 cm over the floor. (It dragged 78 cm along the floor when the stop ended mid-swing, and 27–32 cm
    on a sad, tired walk's stop before the swing's least lift.)"""
    cues = [Cue(0.2, "walk"), Cue(3.0, "idle"), Cue(6.0, "walk"), Cue(9.0, "idle")]
    perf = perform(bandai, cues, seconds=12.0, seed=1, adverbs={"valence": valence, "energy": energy, "turn": turn})
    stops = [k for k, t in enumerate(bandai.transitions) if (t.source, t.target) == (bandai.verb_index("walk"), bandai.verb_index("idle"))]
    window = np.flatnonzero(np.isin(perf.active, stops))
    assert len(window) > 10, "the walk never stopped"
    verb = next(v for v in bandai.verbs if v.holds)
    metrics = measure_feet(verb, perf.planted, perf.report, None, perf.free)
    releases = [b for i in range(len(verb.holds)) for _, b in perf.report.phases[i] if b < perf.planted.num_frames]
    inside = set(window.tolist())
    during = [s for s, b in zip(metrics.slide, releases) if b in inside or b - 1 in inside]
    assert max(during, default=0.0) <= 0.01, during
    # ... and a foot let go there that is still low in the next frame has not moved: it rises in place first. A foot
    # re-placed as the walk faded was kept moving against the walk's velocity at its release while the walk slowed
    # under it: 1.8-3.2 mm in that frame at these points, 7.6 mm at others, 9 mm with the stand on its feet.
    toes = [bandai.skeleton.index(n) for n in ("Toes_L", "Toes_R")]
    pos = perf.planted.global_positions()[:, toes]
    low = pos[:, :, 1] - np.percentile(pos[:, :, 1], 1, axis=0) < 0.02
    first = [
        float(np.hypot(*(pos[b + 1, i, [0, 2]] - pos[b, i, [0, 2]])))
        for i in range(2)
        for _, b in perf.report.phases[i]
        if b + 1 < len(pos) and (b in inside or b - 1 in inside) and low[b + 1, i]
    ]
    assert max(first, default=0.0) <= 0.001, first


def test_one_verb_plays_over_and_over_as_a_graph_of_its_own(verbs, tmp_path):
    # `adverbs view VERB`: a one-shot reach blends its end into its start and reaches again, with no pop
    from adverbs.apps.viewer import load_for_view
    from adverbs.runtime import Simulation

    reach, _ = verbs["bandai_reach"]
    g = Graph.of_verb(reach)
    assert g.verb_names == (reach.name,) and [(t.source, t.target) for t in g.transitions] == [(0, 0)]
    sim = Simulation([g], fps=30)
    c = sim.add_creature()
    sim.run(12.0)
    clip = c.clip()
    pos = clip.global_positions()
    hand = pos[:, reach.skeleton.index("Hand_R"), 1]
    middle = 0.5 * (hand.min() + hand.max())
    assert np.count_nonzero(np.diff(np.sign(hand - middle))) >= 6  # up and down three times or more
    alone, _ = reach.synthesize(reach.points.mean(axis=0))
    speed = lambda p, fps: np.linalg.norm(np.diff(p, axis=0), axis=-1).max() * fps  # noqa: E731
    assert speed(pos, clip.fps) <= 1.5 * speed(alone.global_positions(), alone.fps)
    walk, _ = verbs["cmu_walk"]
    assert [t.added for t in Graph.of_verb(walk).transitions] == [True]  # a cyclic verb's own loop, nothing else
    # the viewer's target: a built verb file gives a graph of that verb; a graph spec a graph; a missing file an error
    save_verb(reach, tmp_path / "reach.verb")
    assert load_for_view(tmp_path / "reach.verb", progress=False)[0].verb_names == (reach.name,)
    with pytest.raises(AdverbsError, match="nothing.toml: no such graph or verb spec file"):
        load_for_view(tmp_path / "nothing.toml", progress=False)


def test_the_compiled_time_warps_are_the_numpy_ones():
    """clock_of / generic_of (compiled, row by row) against timewarp's NumPy functions on the cycle a time falls in,
    over random keytimes and times from the cycle before to the cycle after next."""
    rng = np.random.default_rng(3)
    n = 2000
    keys = np.concatenate([np.zeros((n, 1)), np.cumsum(rng.uniform(0.03, 0.6, (n, 4)), axis=1)], axis=1)
    generic = np.array([0.0, 0.2, 0.45, 0.8, 1.0])
    g = np.concatenate([rng.uniform(-1.5, 2.5, n - 5), [0.0, 1.0, -1.0, 0.2, 0.9999999]])
    lap = np.floor(g)
    want = timewarp.clock_time(g - lap, keys, generic) + lap * keys[:, -1]
    clock = clock_of(g, keys, generic)
    np.testing.assert_array_equal(clock, want)
    end = keys[:, -1]
    lap_c = np.floor(clock / end)
    np.testing.assert_array_equal(generic_of(clock, keys, generic), timewarp.generic_time(clock - lap_c * end, keys, generic) + lap_c)
    np.testing.assert_allclose(generic_of(clock, keys, generic), g, rtol=0, atol=1e-12)


def test_stacked_time_warps_are_the_single_ones():
    """clock_of / generic_of of ``(n, k)`` times: each column as if converted alone."""
    rng = np.random.default_rng(4)
    keys = np.concatenate([np.zeros((50, 1)), np.cumsum(rng.uniform(0.03, 0.6, (50, 4)), axis=1)], axis=1)
    generic = np.array([0.0, 0.2, 0.45, 0.8, 1.0])
    g = rng.uniform(-1.0, 2.0, (50, 3))
    for convert in (clock_of, generic_of):
        out = convert(g, keys, generic)
        for k in range(3):
            np.testing.assert_array_equal(out[:, k], convert(g[:, k], keys, generic))


def test_the_compiled_blend_is_slerp_and_lerp():
    """blend_poses against quat.slerp (from B to A by the weight) and a linear blend, on random rotations of both signs,
    nearly opposite ones and weights 0 (A unset: B's pose) to 1; rows it is not given stay as they were."""
    rng = np.random.default_rng(5)
    c, j = 40, 7
    a = quat.normalize(rng.normal(size=(c, j, 4)))
    b = quat.normalize(rng.normal(size=(c, j, 4)))
    b[0] = -a[0]  # the same rotations, opposite signs
    b[1] = quat.normalize(-a[1] + 1e-6 * rng.normal(size=(j, 4)))
    ta, tb = rng.normal(size=(c, j, 3)), rng.normal(size=(c, j, 3))
    w = rng.uniform(0.0, 1.0, c)
    w[2], w[3] = 0.0, 1.0
    rows = np.arange(c - 5)
    rot, trans = a.copy(), ta.copy()
    rot[2] = np.nan  # weight 0: A may be unset
    blend_poses(rot, trans, b, tb, rows, w[rows])
    want = quat.slerp(b[rows], a[rows], np.broadcast_to(w[rows, None], (len(rows), j)))
    want[2] = b[2]
    np.testing.assert_allclose(rot[rows], want, rtol=0, atol=1e-12)
    np.testing.assert_allclose(trans[rows], w[rows, None, None] * ta[rows] + (1.0 - w[rows, None, None]) * tb[rows], rtol=0, atol=1e-14)
    np.testing.assert_array_equal(rot[c - 5 :], a[c - 5 :])


def test_the_compiled_hold_phases_are_hold_modes():
    """hold_rows (the graph's compiled hold lookup) against planting.hold_modes, for a cycle and a one-shot verb,
    at generic times in other cycles and outside a one-shot motion, written to the feet's columns."""
    rng = np.random.default_rng(6)
    c = 300
    opens = np.array([0.1, 0.6])
    spans = np.sort(rng.uniform(0.0, 0.9, (c, 2, 3)), axis=-1)
    times = opens[:, None] + spans
    cols = np.array([1, 0])
    for cyclic in (True, False):
        g = rng.uniform(-1.5, 2.5, c)
        held, roll, swing = np.zeros((c, 3), dtype=bool), np.full((c, 3), -1.0), np.full((c, 3), -1.0)
        rows = np.arange(0, c, 2)
        hold_rows(g, rows, opens, times, cols, cyclic, held, roll, swing)
        t = g[rows] - np.floor(g[rows]) if cyclic else np.clip(g[rows], 0.0, 1.0)
        inside, turn = hold_modes(cyclic, t[:, None], opens, times[rows])
        np.testing.assert_array_equal(held[rows][:, cols], inside)
        np.testing.assert_allclose(roll[rows][:, cols], turn, rtol=0, atol=1e-15)
        np.testing.assert_allclose(swing[rows][:, cols], swing_lifts(cyclic, t[:, None], opens, times[rows]), rtol=0, atol=1e-15)
        assert not held[1::2].any() and np.all(roll[1::2] == -1.0) and np.all(roll[rows, 2] == -1.0)
        assert np.all(swing[1::2] == -1.0) and np.all(swing[rows, 2] == -1.0)
        if cyclic:  # every value from none to all of the lift, as the swings go by
            lifts = swing[rows][:, cols]
            assert lifts.min() < 0.05 and lifts.max() == 1.0 and 0.05 < np.mean(lifts) < 1.0
        else:
            assert np.all(swing[rows][:, cols] == 0.0)


def test_a_stand_s_blended_holds_never_roll_their_feet():
    """A stand holds both feet to its end ([0, 1, 1]: heel-off at toe-off). Blended at a creature's adverbs its heel-off
    came out 1 - 1e-16, and at the stand's end the feet were rolled 4e-8: enough for the planter to take a foot landing
    there for one lifting off and leave it unheld, 5 mm over the floor. Both lookups now give such a hold no roll."""
    times = np.array([[[0.0, 1.0 - 1e-16, 1.0], [0.0, 1.0, 1.0]]])
    opens = np.zeros(2)
    for g in (0.0, 0.5, 1.0 - 1e-12, 1.0):
        inside, turn = hold_modes(False, np.array([[g]]), opens, times)
        assert inside.all() and np.all(turn == 0.0), (g, turn)
        held, roll, swing = np.zeros((1, 2), dtype=bool), np.full((1, 2), -1.0), np.full((1, 2), -1.0)
        hold_rows(np.array([g]), np.array([0]), opens, times, np.array([0, 1]), False, held, roll, swing)
        assert held.all() and np.all(roll == 0.0), (g, roll)
    # A cycle's hold whose heel lifts at toe-off is flat while held and let go at toe-off.
    inside, turn = hold_modes(True, np.array([[0.3], [0.7]]), np.zeros(1), np.array([[[0.0, 0.6, 0.6]]] * 2))
    assert inside[:, 0].tolist() == [True, False] and turn[:, 0].tolist() == [0.0, 1.0]


def test_root_velocities_undo_the_root_step():
    """The graph's root velocities (compiled) of a step taken by advance_root are the velocities it was taken at."""
    rng = np.random.default_rng(9)
    root = rng.normal(0.0, [10.0, 10.0, 20.0], (200, 3))
    vel = rng.normal(0.0, [1.0, 3.0, 2.0], (200, 3))
    np.testing.assert_allclose(_velocity(root, advance_root(root, vel, 1 / 30), 1 / 30), vel, rtol=0, atol=1e-9)


def test_the_compiled_blend_bookkeeping_is_the_numpy_one(bandai):
    """keep_feet (the body carried by the held feet's slip) and decay_offsets (a decaying pose offset) against the NumPy
    formulas they replace, on real Bandai poses: feet weights of both kinds and none, offsets of all ages."""
    from adverbs.graph._blend_kernel import decay_offsets, keep_feet
    from adverbs.kinematics.fk import forward_kinematics, path_to

    graph = bandai
    body = graph.verbs[0].encoding.body_root
    rng = np.random.default_rng(10)
    c, j = 12, graph.skeleton.num_joints
    rot = quat.normalize(rng.normal(size=(c, j, 4)))
    trans = np.broadcast_to(graph.verbs[1].encoding.base_translations, (c, j, 3)) + rng.normal(0, 0.05, (c, j, 3))
    shown_rot = quat.normalize(rot + rng.normal(0, 0.05, (c, j, 4)))
    shown_trans = trans + rng.normal(0, 0.02, (c, j, 3))
    tips = graph.feet_array
    rows = np.array([0, 2, 3, 5, 7, 11])
    w = rng.uniform(0.0, 1.0, (len(rows), len(tips)))
    w[1] = 0.0  # no foot held in both frames: untouched
    w[2, 0] = 0.0
    root = rng.normal(size=(c, 3))
    got_root, got_trans = root.copy(), np.array(trans)
    n = len(rows)
    free = (np.zeros(n), np.full(n, np.inf), np.full(n, np.inf))  # any speed, any change of velocity: the slip alone
    shown_vel = rng.normal(0, 1.0, (c, 3))
    fade = rng.uniform(0.2, 1.0, n)  # under a decaying offset: the part of the slip left to carry the body
    fade[0] = 1.0
    keep_feet(graph.skeleton.parents, tips, path_to(graph.skeleton.parents, tips), rows, w, rot, got_trans, shown_rot, shown_trans, shown_vel, body,
              graph.inverse_above_body, got_root, root, *free, fade, DT, np.ones(n, dtype=bool))  # fmt: skip
    now = forward_kinematics(graph.skeleton.parents, rot[rows], trans[rows])[0][:, tips]
    was = forward_kinematics(graph.skeleton.parents, shown_rot[rows], shown_trans[rows])[0][:, tips]
    keep = w.sum(axis=1) > 0
    slip = np.einsum("cl,clk->ck", w[keep], (was - now)[keep]) / w[keep].sum(axis=1, keepdims=True)
    slip *= fade[keep, None]
    slip[:, 1] = 0.0
    want_root, want_trans = root.copy(), np.array(trans)
    want_root[rows[keep], 0] += slip[:, 0]
    want_root[rows[keep], 1] += slip[:, 2]
    want_trans[rows[keep], body] += quat.rotate(graph.inverse_above_body, slip)
    np.testing.assert_allclose(got_root, want_root, rtol=0, atol=1e-15)
    np.testing.assert_allclose(got_trans, want_trans, rtol=0, atol=1e-15)
    assert np.array_equal(got_root[rows[1]], root[rows[1]])
    # At a speed asked for (a cosine blend's, player._speeds): the step from where the root was is that long, in the
    # direction of the root's own advance (the verbs' velocities, not the slip); the body root's translation moves
    # with it.
    prev = root - rng.normal(0, 0.03, root.shape)
    speed = rng.uniform(0.5, 3.0, n)
    held_root, held_trans = root.copy(), np.array(trans)
    held_back = np.ones(n, dtype=bool)
    keep_feet(graph.skeleton.parents, tips, path_to(graph.skeleton.parents, tips), rows, w, rot, held_trans, shown_rot, shown_trans, shown_vel, body,
              graph.inverse_above_body, held_root, prev, speed, speed, np.full(n, np.inf), np.ones(n), DT, held_back)  # fmt: skip
    assert not held_back.any()  # no limit: nothing held back
    step = held_root[rows, :2] - prev[rows, :2]
    np.testing.assert_allclose(np.hypot(*step.T), speed * DT, rtol=1e-12, atol=0)
    advance = root[rows, :2] - prev[rows, :2]
    np.testing.assert_allclose(step / np.hypot(*step.T)[:, None], advance / np.hypot(*advance.T)[:, None], rtol=0, atol=1e-12)
    moved = held_root[rows] - root[rows]  # (x, z, heading): the slip (x, 0, z)
    slip = np.stack([moved[:, 0], np.zeros(n), moved[:, 1]], axis=1)
    np.testing.assert_allclose(held_trans[rows, body] - trans[rows, body], quat.rotate(graph.inverse_above_body, slip),
                               rtol=0, atol=1e-15)  # fmt: skip
    # Under a decaying offset, its velocity within ``change`` m/s² of the one shown before (sideways, forward, turn,
    # its step ending at the heading the root has): the slip's step where it is within, else the nearest within.
    change = np.array([0.5, 4.0, 1e3, 4.0, 40.0, 0.0])
    limited_root, limited_trans = root.copy(), np.array(trans)
    held_back = np.zeros(n, dtype=bool)
    keep_feet(graph.skeleton.parents, tips, path_to(graph.skeleton.parents, tips), rows, w, rot, limited_trans, shown_rot, shown_trans, shown_vel, body,
              graph.inverse_above_body, limited_root, root, np.zeros(n), np.full(n, np.inf), change, np.ones(n), DT,
              held_back)  # fmt: skip
    free_root = root.copy()
    free_back = np.ones(n, dtype=bool)
    keep_feet(graph.skeleton.parents, tips, path_to(graph.skeleton.parents, tips), rows, w, rot, np.array(trans), shown_rot, shown_trans, shown_vel, body,
              graph.inverse_above_body, free_root, root, *free, np.ones(n), DT, free_back)  # fmt: skip
    assert not free_back.any()  # no limit: nothing held back
    mid = root[rows, 2] - 0.5 * shown_vel[rows, 2] * DT
    before = quat.rotate(quat.about_y(mid), np.stack([shown_vel[rows, 0], np.zeros(n), shown_vel[rows, 1]], axis=1))
    assert held_back.any() and not held_back.all()  # (the changes above hold some back and not others)
    for i, c_ in enumerate(rows):  # (a row without feet held, too: a body catching up with its verb, lo 0, hi inf)
        wanted = (free_root[c_, :2] - root[c_, :2]) / DT
        got = (limited_root[c_, :2] - root[c_, :2]) / DT
        gap = np.hypot(*(wanted - before[i, [0, 2]]))
        assert held_back[i] == (gap > change[i] * DT), (i, gap, change[i] * DT)  # whether the limit held it back
        if gap <= change[i] * DT:
            np.testing.assert_allclose(got, wanted, rtol=0, atol=1e-12)
        else:
            np.testing.assert_allclose(np.hypot(*(got - before[i, [0, 2]])), change[i] * DT, rtol=0, atol=1e-12)
            unit = (wanted - before[i, [0, 2]]) / gap
            np.testing.assert_allclose(got, before[i, [0, 2]] + unit * change[i] * DT, rtol=0, atol=1e-12)

    off_rot, off_rot_vel = rng.normal(0, 0.3, (c, j, 3)), rng.normal(0, 2.0, (c, j, 3))
    off_trans, off_trans_vel = rng.normal(0, 0.05, (c, j, 3)), rng.normal(0, 0.5, (c, j, 3))
    since, halflife = rng.uniform(0.0, 2.0, len(rows)), rng.uniform(0.05, 0.4, len(rows))
    got_rot, got_trans = rot.copy(), np.array(trans)
    decay_offsets(rows, since, halflife, off_rot, off_rot_vel, off_trans, off_trans_vel, got_rot, got_trans)
    y = 2.0 * np.log(2.0) / halflife[:, None, None]
    t = since[:, None, None]
    spring = lambda x0, v0: (x0 + (v0 + y * x0) * t) * np.exp(-y * t)  # noqa: E731
    want_rot, want_trans = rot.copy(), np.array(trans)
    want_rot[rows] = quat.mul(quat.exp(spring(off_rot[rows], off_rot_vel[rows])), rot[rows])
    want_trans[rows] += spring(off_trans[rows], off_trans_vel[rows])
    np.testing.assert_allclose(got_rot, want_rot, rtol=0, atol=1e-14)
    np.testing.assert_allclose(got_trans, want_trans, rtol=0, atol=1e-15)
