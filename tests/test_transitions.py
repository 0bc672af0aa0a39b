"""Every kind of transition of both shipped graphs, measured on the frames a performance writes (issue 32).

A script per graph plays every kind of edge the graph has: a start (idle → walk) and a stop (walk → idle), walk ↔
run, idle ↔ each gesture, and an adverb cue in the middle of a gesture, with each verb's loops into itself between.
Over each transition and the frames after it until the next (at most half a second), read off the frames alone (never the planter's state):

* **Toes.** No toe travels further across the floor while within 2 cm of its contact height than its verbs' own do
  (each verb played alone at the adverbs in effect: both points while a cue's change eases), plus 2 cm.
* **Hips.** The pelvis's vertical range is within 1.2x the unplanted motion's over the same frames (plus 2 mm, for
  a stand whose hips hardly move). The planter lowered the hips wherever a trailing leg could not reach its foot:
  1.2-1.75x the unplanted over the walk's loops here, and 41 cm in the CMU run; now a foot the hips have passed
  rises onto its ball.
* **Joints.** No joint of the arms, the legs or the trunk turns faster than 1.5x the fastest of that part in its
  verbs' own, over the window's steps (from its frame before to its last).
* **Root.** The body root's horizontal acceleration stays within 1.5x its verbs' own.

An adverb cue is a window too, from the cue to half a second after its ease is over, measured against the verbs it
plays through at both points. Until session 48 no window covered the fixed script's cue in the bow (its valence
-0.7 to 0.7 over half a second turned the legs at 1.95x the bow's own): cues now ease as long as they need.

The scripts' adverb points and seeds are not the ones the planter was tuned on.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from adverbs import load_graph
from adverbs.errors import AdverbsWarning
from adverbs.graph.performance import Cue, perform
from adverbs.graph.planted import know_levels, plant, planter
from adverbs.graph.player import first_frame, step
from adverbs.graph.queue import command
from adverbs.graph.state import new_state
from adverbs.kinematics.fk import forward_kinematics

from test_edges import FPS, _angular_speed, _contact, _parts, _settled, _windows, low_travel

GRAPHS = Path(__file__).resolve().parent.parent / "graphs"
SCRIPTS = {
    "bandai": (
        [(0.5, "walk"), (3.0, "run"), (6.0, "walk"), (8.5, "idle"), (10.5, "reach"), (14.5, "bow"),
         (16.0, {"valence": 0.7}), (19.5, "guide"), (23.5, "bye"), (29.5, "walk"), (32.0, "idle")],
        35.0, ("Toes_L", "Toes_R"),
        {("idle", "walk"), ("walk", "idle"), ("walk", "run"), ("run", "walk")}
        | {(a, b) for g in ("reach", "bow", "guide", "bye") for a, b in (("idle", g), (g, "idle"))},
    ),
    "cmu": (
        [(0.5, "walk"), (3.0, "run"), (6.0, "walk"), (9.0, "run"), (11.5, "walk")],
        14.0, ("ltoes", "rtoes"), {("walk", "run"), ("run", "walk")},
    ),
}  # fmt: skip
POINTS = {
    "bandai": [(23, {"valence": 0.4, "energy": -0.5, "turn": 15.0}), (17, {"valence": -0.7, "energy": 0.6, "turn": -10.0})],
    "cmu": [(11, {"walk_speed": 1.1, "run_speed": 2.8, "turn": -15.0}), (17, {"walk_speed": 1.5, "turn": 25.0})],
}


@pytest.fixture(scope="module")
def graphs():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        return {name: load_graph(GRAPHS / f"{name}.toml") for name in SCRIPTS}


def _measures(perf, graph, toes):
    """What the frames of ``perf`` show, frame by frame: its toes' positions, each part's fastest joint (rad/s, over
    the step into each frame; 0 at the first) and the root's acceleration."""
    pos = perf.planted.global_positions()[:, toes]
    speed = np.concatenate([np.zeros((1, graph.skeleton.num_joints)), _angular_speed(perf.planted.rotations)])
    parts = {p: speed[:, j].max(axis=1) for p, j in _parts(graph).items()}
    return pos, parts, _root_acceleration(perf, graph)


STILL = 0.1  # m/s²: the least root acceleration a verb is taken to have of its own


def _own(graph, verb, toes, seed, adverbs):
    """``verb`` played alone (a cyclic verb after its first second): how far a low toe travels, each part's fastest
    joint and the root's fastest acceleration, at least ``STILL``: a stand stays where it stands
    (``specs/bandai_idle.toml``, ``in_place``), its own acceleration is nothing, and 1.5x nothing would bound the
    settling of a body a stop or a gesture left there (up to 0.07 m/s² here; the walk's own is 4-6)."""
    cyclic = graph.verbs[graph.verb_index(verb)].cyclic
    pos, parts, acc = _measures(perform(graph, [], seconds=6.0, seed=seed, start=verb, adverbs=adverbs, stay=True), graph, toes)
    frames = np.arange(30 if cyclic else 2, len(pos))
    return {"toe": low_travel(pos, _contact(pos), frames), "acc": max(float(acc[frames].max()), STILL)} | {
        p: float(s[frames].max()) for p, s in parts.items()
    }


@pytest.mark.parametrize("name, verb", [("cmu", "walk"), ("cmu", "run"), ("bandai", "walk"), ("bandai", "idle"), ("bandai", "bow")])
def test_a_verb_played_alone_stays_in_it(graphs, name, verb):
    """``perform(stay=True)``, the verbs' own every bound here is measured against: the verb plays on through its
    loops (a gesture into the stand, where it stays); the same seed without ``stay`` wanders the graph by likelihood
    (at these seeds into another verb: the reference the tests and the benchmark used until session 43)."""
    graph = graphs[name]
    alone = perform(graph, [], seconds=20.0, seed=5, start=verb, stay=True)
    then = {"bow": "idle"}.get(verb, verb)
    names = [graph.verb_names[v] for v in alone.verb]
    assert set(names) <= {verb, then} and names[-1] == then, sorted(set(names))
    assert (alone.active < 0).any() and all(
        graph.transitions[k].source == graph.transitions[k].target for k in set(alone.active[alone.verb == graph.verb_index(then)]) if k >= 0
    )
    wandering = perform(graph, [], seconds=20.0, seed=5, start=verb)
    assert len({graph.verb_names[v] for v in wandering.verb} - {verb, then}) > 0


def _points_in_effect(adverbs, script, eases):
    """``(start, end, adverbs)`` of each adverb point a script plays at, in seconds: from its cue (or 0) until the
    next point's ease is over (``eases``: each cue's ``(time, seconds)``, :attr:`Performance.eases`)."""
    changes = [(0.0, dict(adverbs))]
    for t, v in script:
        if isinstance(v, dict):
            changes.append((t, {**changes[-1][1], **v}))
    ends = [t + dict(eases)[t] for t, _ in changes[1:]] + [np.inf]
    return [(t, end, p) for (t, p), end in zip(changes, ends)]


def _cue_windows(perf, graph):
    """Frames ``("cue", verb, a, b)`` of every adverb cue of ``perf``: from the frame before it until half a second
    after its ease is over, ``verb`` what it played at the cue."""
    out = []
    for t, over in perf.eases:
        a = max(int(round(t * FPS)) - 1, 0)
        b = min(len(perf.verb), int(round((t + over) * FPS)) + int(FPS / 2))
        out.append(("cue", graph.verb_names[perf.verb[a]], a, b))
    return out


_PLAYED: dict = {}


def _played(graph, name, seed, adverbs, script=None):
    """Graph ``name``'s script played at ``seed`` and ``adverbs``, measured window by window: ``(source, target, a, b,
    shown, own)``, ``shown`` what the window's frames show (a low toe's travel, each part's fastest joint, the root's
    fastest acceleration, the hips' planted and unplanted ranges) and ``own`` the same of its verbs played alone at the
    adverbs in effect (an adverb cue changes them, over its ease: both while it eases), the larger of the two.
    Each cue's verb stays until the next cue (``perform(stay=True)``), so the windows are the script's own.
    ``script``: ``(cues, seconds, toe names, kinds)`` played instead of :data:`SCRIPTS`' ``name`` (kept under
    ``name``)."""
    if (name, seed) in _PLAYED:
        return _PLAYED[name, seed]
    script, seconds, toe_names, kinds = SCRIPTS[name] if script is None else script
    cues = [Cue(t, adverbs=v) if isinstance(v, dict) else Cue(t, v) for t, v in script]
    perf = perform(graph, cues, seconds=seconds, seed=seed, adverbs=adverbs, start=graph.verb_names[0], stay=True)
    names = graph.skeleton.names
    toes = [names.index(n) for n in toe_names]
    pelvis = next(v for v in graph.verbs if v.constraints).leg_chains.above[-1]
    pos, parts, acc = _measures(perf, graph, toes)
    hips, free_hips = perf.planted.global_positions()[:, pelvis, 1], perf.free.global_positions()[:, pelvis, 1]
    contact = _contact(pos)
    windows = _windows(perf, graph, {(a, b) for a in graph.verb_names for b in graph.verb_names})
    assert kinds <= {(s, t) for s, t, _, _ in windows}, f"the script should play every kind: {kinds} in {windows}"
    points = _points_in_effect(adverbs, script, perf.eases)
    owns = [{v: _own(graph, v, toes, seed, p) for v in graph.verb_names} for _, _, p in points]
    run_walk = [k for k, tr in enumerate(graph.transitions) if (graph.verb_names[tr.source], graph.verb_names[tr.target]) == ("run", "walk")]
    out = []
    for s, t, a, b, verbs, k in _settled(perf, graph, windows) + [(*w, set(), -1) for w in _cue_windows(perf, graph)]:
        frames = np.arange(*windows[k][2:]) if k >= 0 else np.arange(a, b)  # a toe's travel, the hips: the whole window
        own = [o for (start, end, _), o in zip(points, owns) if start <= b / FPS and a / FPS < end]
        verbs = verbs | {graph.verb_names[v] for v in perf.verb[a:b]} | {t} | ({s} if s != "cue" else set())
        ref = {k: max(o[v][k] for o in own for v in verbs) for k in own[0][t]}
        shown = {"toe": low_travel(pos, contact, frames, (a, b) if k >= 0 else None), "acc": float(acc[a:b].max())}
        shown |= {p: float(speed[a:b].max()) for p, speed in parts.items()}
        shown |= {"hips": float(np.ptp(hips[frames])), "free hips": float(np.ptp(free_hips[frames]))}
        shown["slowing"] = bool(np.isin(perf.active[frames], run_walk).any())
        out.append((s, t, a, b, shown, ref))
    _PLAYED[name, seed] = out
    return out


@pytest.mark.parametrize("name, seed, adverbs", [(n, s, a) for n in SCRIPTS for s, a in POINTS[n]])
def test_every_transition_keeps_its_toes_and_hips(graphs, name, seed, adverbs):
    failures = []
    for s, t, a, _, shown, ref in _played(graphs[name], name, seed, adverbs):
        # Not yet held: Bandai's run → walk re-places the run's stance foot, left behind as the body slows, in a
        # catch-up step (up to 4 mm past this bound at seed 17); test_edges bounds its speed. Issue 32's note.
        slowing = name == "bandai" and shown["slowing"]
        bound = ref["toe"] + NOT_YET.get((name, s, t, "toe"), 0.02)
        if shown["toe"] > bound and not slowing:
            failures.append(f"{s}→{t} at {a / FPS:.2f} s: a low toe travels {shown['toe'] * 1000:.0f} mm (bound {bound * 1000:.0f})")
        if shown["hips"] > 1.2 * shown["free hips"] + 0.002:
            failures.append(
                f"{s}→{t} at {a / FPS:.2f} s: the hips range {shown['hips'] * 1000:.0f} mm, unplanted {shown['free hips'] * 1000:.0f}"
            )
    assert not failures, "\n".join(failures)


# Not yet within 1.5x of their verbs' own, measured against the verbs played alone (staying, as perform(stay=True)
# plays them; until session 43 the reference wandered the graph, and took in the very transitions it bounded): the
# worst ratio over this file's scripts today, which a change may lower and must not raise. Issue 32's note. Since
# session 44 the scripts themselves stay (each cue's verb plays until the next cue), so their windows are the cues'. The bow's
# and the stand's trunk entries came with the fix to a one-shot waiting at its end, which showed its first pose: the
# bow alone snapped its head back to its start at 92 deg/s when it ended, and that snap was its "own" (now 22).
NOT_YET = {
    # (the CMU walk → run toe at 0.035 m over its verbs' own until session 52 gave a foot's first stance in a verb the
    # verb's contact level: test_a_runs_first_landing_after_a_walk_comes_down_at_the_runs_level; Bandai's walk → run
    # and run → run, 0.025 until session 48)
    # (a stand's loop into itself, its legs at 22.4x the stand's own until session 53: the stop's trailing foot, let go
    # once the other had landed, landed 0.2 s into the stand's loop, which starts the frame after every stop ends, its
    # knee at 230 deg/s where the stand's own legs turn at 10. The half second after a transition where its landing
    # settles is measured against its verbs as well as the next's now: test_edges._settled)
    # (Bandai's idle → bow trunk at 2.4x and its idle → reach legs at 1.7x until session 55 paced the blends between
    # standing verbs: test_a_blend_between_standing_verbs_turns_no_part_faster_than_its_verbs. A sad stand holds its
    # head 25° from a sad bow's, and a bow cutting the stand's loop short took the head there in 0.2 s of an
    # inertial decay, 65°/s; the reach's legs went 1.7x theirs through the same cut. The legs at 3.95x until a foot
    # stepped after a stop was held again, session 47; the trunk at 3.1x until session 45)
    # (a stand's loop into itself turned the trunk at 1.9x until it blended into 0.7 of the stand, session 45)
    # (a stop's root at 1.85x until session 47: its carried speed was a frame ahead of the walk's, and a blend into a
    # one-shot now changes the carried body's velocity no faster than its verbs' own: test_a_stop_brakes_as_its_verbs_do)
    # (the walk ↔ run arms, a CMU forearm bending 80° in 0.19 s at 3.4x, 2.5x and Bandai's at 1.6x, and a stop's at
    # 1.65x, until session 46 carried the arms on past those blends: tests/test_arms.py)
    # (the CMU walk → run root at 1.55x until session 50 carried the body's lag on past the blend, 1.6x until session 47)
    # (the CMU walk → walk toe at 0.035 until session 51 moved a swinging foot's contact level with the verbs shown:
    # a foot let go in a run was lowered by the run's level in the walk, test_a_foot_swung_from_a_run_into_a_walk_...)
}  # fmt: skip


@pytest.mark.parametrize("name, seed, adverbs", [(n, s, a) for n in SCRIPTS for s, a in POINTS[n]])
def test_every_transition_keeps_its_joints_and_root(graphs, name, seed, adverbs):
    """No joint of a part turns faster than 1.5x that part's fastest in its verbs' own, and the root accelerates no
    harder than 1.5x theirs, in every window but those :data:`NOT_YET` names, which stay within what they show today."""
    failures = []
    for s, t, a, _, shown, ref in _played(graphs[name], name, seed, adverbs):
        for what in ("arms", "legs", "trunk", "acc"):
            ratio = shown[what] / ref[what]
            bound = NOT_YET.get((name, s, t, what), 1.5)
            if ratio > bound:
                failures.append(f"{s}→{t} at {a / FPS:.2f} s: {what} at {ratio:.2f}x its verbs' own (bound {bound:.2f})")
    assert not failures, "\n".join(failures)


@pytest.mark.parametrize("name", ["cmu_walk", "bandai_styled_walk", "cmu_run", "bandai_run"])
def test_a_planted_cycle_keeps_its_hips(verbs, run_verbs, name):
    """``synth --cycles 3`` dropped a Bandai walk's hips 6-7 cm once a cycle (93 mm range against 28 unplanted) and the
    CMU run's 41 cm: the planted pelvis's vertical range over three cycles, at an example, between two far examples and
    at the examples' mean, is now within 1.2x the unplanted (+2 mm)."""
    from adverbs.graph.performance import repeat

    verb = (verbs | run_verbs)[name][0]
    far = np.argmax(np.linalg.norm(verb.points - verb.points[0], axis=1))
    pelvis = verb.leg_chains.above[-1]
    for p in (verb.points[-1], (verb.points[-1] + verb.points[far]) / 2, verb.points.mean(axis=0)):
        looped, _ = repeat(verb, p, cycles=3)
        planted = np.ptp(looped.planted.global_positions()[:, pelvis, 1])
        unplanted = np.ptp(looped.free.global_positions()[:, pelvis, 1])
        assert planted <= 1.2 * unplanted + 0.002, (np.round(p, 2), planted, unplanted)


@pytest.mark.parametrize("seed, adverbs", POINTS["bandai"])
def test_a_standing_foot_re_placed_steps_rather_than_hops(graphs, seed, adverbs):
    """A gesture that finds the stand's foot 9-10 cm from where it has it re-places the foot. Lifted 3 cm in one frame
    and dropped in one, the knee turned 470-630 deg/s (15-20° in a frame, in a figure standing still); stepping (lift
    first, then travel, then down) it turns at most 300 deg/s (237-250 measured on another script), whatever the
    walk's own fastest knee (550-1,150 deg/s)."""
    graph = graphs["bandai"]
    script, seconds, _, _ = SCRIPTS["bandai"]
    cues = [Cue(t, adverbs=v) if isinstance(v, dict) else Cue(t, v) for t, v in script]
    perf = perform(graph, cues, seconds=seconds, seed=seed, adverbs=adverbs, start="idle")
    names = graph.skeleton.names
    knees = [names.index("LowerLeg_L"), names.index("LowerLeg_R")]
    speed = _angular_speed(perf.planted.rotations)[:, knees].max(axis=1)
    gestures = {("idle", g) for g in ("reach", "bow", "guide", "bye")} | {(g, "idle") for g in ("reach", "bow", "guide", "bye")}
    windows = _windows(perf, graph, gestures)
    assert len(windows) >= 6, windows
    fastest = max(speed[max(a - 1, 0) : b].max() for _, _, a, b in windows)
    assert np.degrees(fastest) <= 300.0, np.degrees(fastest)


def test_a_foot_re_placed_after_a_stop_is_held_again(graphs):
    """The fixed script's stop at seed 17 ends with the right foot 16-24 cm from where the stand has it, so it steps
    (9.67-10.07 s). The planter then left it unheld until the reach opened new holds half a second later, 5 mm over
    the floor, and the reach's opening dropped it: the legs turned at 3.9x the stand's and the reach's own. (A stand's
    blended holds rolled its feet by 4e-8: ``test_graph``'s ``test_a_stand_s_blended_holds_never_roll_their_feet``.)
    Now both feet are held from the step's landing to the reach, and the reach's legs move as their verbs' do."""
    graph = graphs["bandai"]
    adverbs = dict(POINTS["bandai"])[17]
    script, seconds, _, _ = SCRIPTS["bandai"]
    cues = [Cue(t, adverbs=v) if isinstance(v, dict) else Cue(t, v) for t, v in script]
    perf = perform(graph, cues, seconds=11.0, seed=17, adverbs=adverbs, start="idle", stay=True)
    held = _held(perf)
    stepped = ~held[int(9.75 * FPS) : int(10.1 * FPS), 1]
    assert stepped.all(), "the script should step the right foot after its stop"
    assert held[int(10.25 * FPS) : int(10.5 * FPS)].all(), np.flatnonzero(~held.all(axis=1)) / FPS


def test_a_stop_stands_on_a_foot_throughout(graphs):
    """A stop's trailing foot, 15 cm from where the stand has it while the walk still swung the other, was let go to be
    re-placed before the other landed: for 0.13 s neither foot was within 1 cm of the floor (neither toe nor ankle),
    the fixed script at seed 17. A standing creature now steps one foot at a time (``planted._others_down``). Read off
    the frames: every frame of every stop has a toe or an ankle within 1 cm of its lowest, in the fixed script and in
    random gesture scripts."""
    from test_edges import gesture_script

    graph = graphs["bandai"]
    names = graph.skeleton.names
    joints = [names.index(n) for n in ("Toes_L", "Toes_R", "Foot_L", "Foot_R")]
    stops = [k for k, t in enumerate(graph.transitions) if graph.verbs[t.source].cyclic and not graph.verbs[t.target].cyclic]
    script, seconds, _, _ = SCRIPTS["bandai"]
    cues = [Cue(t, adverbs=v) if isinstance(v, dict) else Cue(t, v) for t, v in script]
    runs = [perform(graph, cues, seconds=seconds, seed=s, adverbs=a, start="idle", stay=True) for s, a in POINTS["bandai"]]
    runs += [perform(graph, *gesture_script(s)[:1], seconds=28.0, seed=s, adverbs=gesture_script(s)[1], start="idle") for s in (203, 207)]
    checked = 0
    for perf in runs:
        pos = perf.planted.global_positions()[:, joints, 1]
        down = (pos - np.percentile(pos, 1, axis=0) <= 0.01).reshape(-1, 2, 2).any(axis=1)
        stopping = np.isin(perf.active, stops)
        checked += int(stopping.sum())
        assert down[stopping].any(axis=1).all(), np.flatnonzero(stopping & ~down.any(axis=1)) / FPS
    assert checked > 60, checked


@pytest.mark.parametrize("seed", [207, 205, 206])
def test_a_stop_brakes_as_its_verbs_do(graphs, seed):
    """A stop's body, carried by its feet at the speed of the blend of the walk's and the stand's own velocities, took
    that speed at the step's end where the root's own advance takes the step's start: the first step of the blend
    skipped a frame's change (1.88 -> 1.51 m/s in a frame as the walk slowed after a heel strike, 11 m/s²), and the
    blend into the stand changed the body's velocity as fast as the blend did. Now the carried step goes at the
    step's start, and a blend into a one-shot changes it no faster than its verbs' own (``player.carry_limits``).
    Random gesture scripts whose stops went 1.50-1.58x their verbs' own: every stop's root acceleration within 1.25x
    (0.99-1.02x here; the issue's bound is 1.5x). (Seed 201's script no longer stops since session 55 paced the
    gestures' blends: 207 stops four times.)"""
    from test_edges import gesture_script

    graph = graphs["bandai"]
    cues, adverbs = gesture_script(seed)
    perf = perform(graph, cues, seconds=28.0, seed=seed, adverbs=adverbs, start="idle")
    acc = _root_acceleration(perf, graph)
    own = max(
        _root_acceleration(perform(graph, [], seconds=6.0, seed=seed, start=v, adverbs=adverbs, stay=True), graph)[2:].max()
        for v in ("walk", "idle")
    )
    stops = _windows(perf, graph, {("walk", "idle")})
    assert stops, "the script should stop"
    worst = max(acc[a:b].max() for _, _, a, b in stops)
    assert worst <= 1.25 * own, f"a stop's root at {worst / own:.2f}x its verbs' own"


@pytest.mark.parametrize(
    "seed, adverbs", [(4, {}), (6, {"walk_speed": 0.9, "run_speed": 3.8, "turn": 20.0}), (7, {"run_speed": 2.3})]
)
def test_a_walk_breaking_into_a_run_speeds_up_as_its_verbs_do_and_catches_up(graphs, seed, adverbs):
    """A CMU walk → run blends a quarter of each cycle, 0.17-0.2 s, and took the body from the walk's speed to the
    run's at 14-21 m/s² (the run's own 8-12): 1.55-2.07x. Its velocity now changes no faster than its verbs' own
    (``player.carry_limits``), and a body the blend left behind the run's velocity catches up at that rate past the
    blend (``GraphState.lagging``): from the blend's start to a second after it, within 1.25x its verbs' own; and a
    second after, it runs at the run's own pace (its mean speed over a second within the run alone's, over every
    second of it)."""
    graph = graphs["cmu"]
    perf = perform(graph, [Cue(0.3, "walk"), Cue(2.0, "run")], seconds=5.0, seed=seed, adverbs=adverbs, stay=True)
    acc = _root_acceleration(perf, graph)
    blends = _windows(perf, graph, {("walk", "run")})
    assert len(blends) == 1, blends
    _, _, a, b = blends[0]
    own = max(
        _root_acceleration(perform(graph, [], seconds=6.0, seed=seed, start=v, adverbs=adverbs, stay=True), graph)[30:].max()
        for v in ("walk", "run")
    )
    assert acc[a : b + int(FPS)].max() <= 1.25 * own, f"{acc[a : b + int(FPS)].max() / own:.2f}x its verbs' own"
    assert not perf.state.lagging[0], "caught up by the end"

    def speeds(p):  # the body root's mean horizontal speed over each second, m/s
        xz = p.planted.global_positions()[:, graph.verbs[0].encoding.body_root][:, [0, 2]]
        step = np.linalg.norm(np.diff(xz, axis=0), axis=1)
        return np.convolve(step, np.ones(int(FPS)), "valid")

    alone = speeds(perform(graph, [], seconds=6.0, seed=seed, start="run", adverbs=adverbs, stay=True))[int(FPS) :]
    after = speeds(perf)[b + int(FPS) :]
    assert alone.min() - 1e-3 <= after.min() and after.max() <= alone.max() + 1e-3, (after, alone.min(), alone.max())


def _toe_by_phase(graph, adverbs, seed, cues, seconds, after, toe="ltoes"):
    """One CMU creature driven frame by frame as ``perform`` drives it (``player.step``, then the graph's planter),
    starting in the walk, told ``cues`` (``(seconds, verb)``): its ``toe``'s height ``(g, y)`` over the walk's first
    whole cycle (played alone or in its loop) from phase 0.5 on, after ``after`` seconds, phase unwrapped past 1."""
    state = new_state(graph, 1, seed, "walk", points=graph.point(adverbs)[None], stay=True)
    feet = planter(graph, 1)
    walk, j = graph.verb_index("walk"), graph.skeleton.names.index(toe)
    out, prev, wrapped = [], None, False
    for f in range(int(seconds * FPS)):
        for t, verb in cues:
            if f == int(round(t * FPS)):
                command(state, 0, verb, stay=True)
        know_levels(feet, state)
        frame = first_frame(state) if f == 0 else step(state, 1.0 / FPS)
        rot, trans, _ = plant(feet, frame, 1.0 / FPS, state.alone, state.standing)
        k = state.active[0]
        one = state.verb[0] == walk and (k < 0 or graph.transitions[k].source == graph.transitions[k].target)
        g = float(state.g[0])
        if f / FPS < after or not one or (not out and g < 0.5):
            if out:
                break
            continue
        wrapped |= prev is not None and g < prev
        if wrapped and g >= 0.5:
            break
        out.append((g + wrapped, forward_kinematics(graph.skeleton.parents, rot, trans)[0][0, j, 1]))
        prev = g
    return np.array(out)


@pytest.mark.parametrize("seed", range(100, 106))
def test_a_foot_swung_from_a_run_into_a_walk_comes_down_as_the_walk_brings_it(graphs, seed):
    """The planter lowers a swinging foot by its verb's contact level, which it took as the foot left the floor. A
    CMU run stands its feet about 11 mm over their contact height and the walk 12 mm under it: a foot let go in the
    run and swung into the walk it slowed to was lowered 23 mm too far, came down a frame early and ran on along the
    floor (a low toe 48 mm, the walk's own 20). The planter now keeps each foot's level in each verb and moves a
    free foot's as the verbs shown change (``planted._rebase_hover``): over the walk's first landing after a run, the
    left toe (within 4 cm of its lowest) is within 3.5 mm of where the walk alone has it at the same phase: 0.6-3.0 mm
    at these six points, 2.8-10.8 before. (At 101 and 105 the two verbs' levels are alike and it was 2.8 and 3.1
    before too: what is left is the walk's other differences from its own there, the planter's pelvis and the other
    foot.)"""
    rng = np.random.default_rng(seed)
    adverbs = {"walk_speed": rng.uniform(0.9, 1.7), "run_speed": rng.uniform(2.2, 4.0), "turn": rng.uniform(-35, 35)}
    graph = graphs["cmu"]
    alone = _toe_by_phase(graph, adverbs, seed, [], 4.0, 1.5)
    after = _toe_by_phase(graph, adverbs, seed, [(0.5, "run"), (3.0, "walk")], 6.0, 3.0)
    landing = (after[:, 0] >= 0.8) & (after[:, 0] <= 1.3)
    assert after[0, 0] < 0.8 and after[-1, 0] > 1.3 and landing.sum() > 10, after[:, 0]
    ref = np.interp(after[landing, 0], alone[:, 0], alone[:, 1])
    low = ref - alone[:, 1].min() < 0.04
    assert low.sum() >= 5
    off = np.abs(after[landing, 1] - ref)[low]
    assert off.max() <= 0.0035, f"{off.max() * 1000:.1f} mm from the walk's own"


@pytest.mark.parametrize("seed, adverbs", [(3, {"walk_speed": 1.2, "run_speed": 3.0, "turn": 10.0}), (5, {"walk_speed": 1.6, "run_speed": 2.4})])
@pytest.mark.parametrize("verb, other", [("walk", "run"), ("run", "walk")])
def test_a_command_during_a_cycles_loop_lets_the_loop_play_on(graphs, seed, adverbs, verb, other):
    """A command in the middle of a CMU walk's or run's loop into itself, for a way on whose region the next cycle has
    not reached, cut the loop short: the next cycle took over where the loop's B was, found the way on's region gone
    by, and began the loop again, late, from there (a run's loop then took 0.07 s, its blend weight going 0.40, 0.56,
    0.01; a landing toe slid 13 cm further than the run's own). The loop now plays on: the frames are those of the
    same performance without the command until the loop is over, and the way on is the next transition (the walk →
    run the frame after it, as before; the run → walk at its region)."""
    graph = graphs["cmu"]
    plain = perform(graph, [Cue(0.3, verb)], seconds=4.0, seed=seed, adverbs=adverbs, start=verb, stay=True)
    a = [a for _, _, a, _ in _windows(plain, graph, {(verb, verb)})][1]
    end = a + int(np.argmax(plain.active[a:] != plain.active[a]))  # the first frame after the loop
    told = perform(
        graph, [Cue(0.3, verb), Cue((a + end) // 2 / FPS, other)], seconds=4.0, seed=seed, adverbs=adverbs, start=verb,
        stay=True,
    )  # fmt: skip
    assert np.array_equal(told.planted.rotations[:end], plain.planted.rotations[:end])
    assert np.array_equal(told.planted.translations[:end], plain.planted.translations[:end])
    after = told.active[end:]
    way_on = graph.transitions[after[np.argmax(after >= 0)]]  # the next transition: the way on, not another loop
    assert told.active[end] < 0 and (graph.verb_names[way_on.source], graph.verb_names[way_on.target]) == (verb, other)


def _held(perf):
    """Whether each foot is held at each frame ``(F, L)``, from the planting report's hold phases."""
    held = np.zeros((len(perf.verb), len(perf.report.phases)), dtype=bool)
    for i, runs in enumerate(perf.report.phases):
        for a, b in runs:
            held[a:b, i] = True
    return held


def _root_acceleration(perf, graph):
    """The body root's horizontal acceleration at each frame ``(F,)``, m/s², read off the frames."""
    xz = perf.planted.global_positions()[:, graph.verbs[0].encoding.body_root][:, [0, 2]]
    v = np.diff(xz, axis=0) * FPS
    return np.r_[0.0, 0.0, np.linalg.norm(np.diff(v, axis=0), axis=1) * FPS]


@pytest.mark.parametrize("seed, adverbs", POINTS["bandai"])
def test_a_verb_looping_after_a_transition_keeps_its_own_pace(graphs, seed, adverbs):
    """A walk or run looping into itself after a change of verb accelerates its root at most 1.5x as it does alone.
    Under the decaying offset an interruption leaves, the body was carried by the feet's whole slip: a run dipped to
    1.9 m/s and lurched on at 2.6 for a second (18-22 m/s², the run's own 6); now no slower than its root's own.
    (The script wanders between its cues: since session 55 paced gestures leave seed 17 two loops, not three.)"""
    graph = graphs["bandai"]
    script, seconds, _, _ = SCRIPTS["bandai"]
    cues = [Cue(t, adverbs=v) if isinstance(v, dict) else Cue(t, v) for t, v in script]
    perf = perform(graph, cues, seconds=seconds, seed=seed, adverbs=adverbs, start="idle")
    acc = _root_acceleration(perf, graph)
    failures, checked = [], 0
    for verb in ("walk", "run"):
        alone = perform(graph, [], seconds=6.0, seed=seed, start=verb, adverbs=adverbs, stay=True)
        own = _root_acceleration(alone, graph)[30:].max()
        for _, _, a, b in _windows(perf, graph, {(verb, verb)}):
            checked += 1
            if acc[a:b].max() > 1.5 * own:
                failures.append(f"{verb} loop at {a / FPS:.2f} s: {acc[a:b].max():.1f} m/s² (its own {own:.1f})")
    assert checked >= 2 and not failures, "\n".join(failures)


@pytest.mark.parametrize("cue", [1.2, 2.0])
def test_an_adverb_eased_under_a_fresh_gesture_moves_its_body_smoothly(graphs, cue):
    """A valence cue early in a bow, while the idle→bow interruption's offset still decays. The held feet's slip (the
    stance changing with the valence) carried the body while the offset lived and stopped in one frame when it was
    over: the body root went from 0.1 m/s to rest (3.8 and 2.6 m/s² here; the bow's own 0.4-0.6). The carry now ends
    with the offset (``player._keep_feet``'s fade)."""
    graph = graphs["bandai"]
    cues = [Cue(0.5, "bow"), Cue(cue, adverbs={"valence": 0.8})]
    perf = perform(graph, cues, seconds=5.0, seed=3, adverbs={"valence": -0.3, "energy": 0.2}, start="idle")
    acc = _root_acceleration(perf, graph)
    bow = np.flatnonzero((perf.verb == graph.verb_index("bow")) & (perf.active < 0))
    assert len(bow) > 90 and acc[bow].max() <= 1.0, acc[bow].max()


@pytest.mark.parametrize("seed, adverbs", POINTS["cmu"])
def test_a_loop_begun_late_keeps_its_verbs_pace(graphs, seed, adverbs):
    """A verb's loop into itself begun near the end of its region (a walk → run that ended there) was stretched to the
    shortest blend, 0.1 s, so the run's clock ran at a tenth of its speed: its root went from 3 to 0.3 m/s and back
    within four frames. A loop blends two instances of one verb at one phase, so it now takes what is left of its
    region: the body root never goes slower in a loop than half its verb's own slowest."""
    graph = graphs["cmu"]
    script, seconds, _, _ = SCRIPTS["cmu"]
    perf = perform(graph, [Cue(t, v) for t, v in script], seconds=seconds, seed=seed, adverbs=adverbs, start="walk")
    body = graph.verbs[0].encoding.body_root

    def speeds(p):
        xz = p.planted.global_positions()[:, body][:, [0, 2]]
        return np.r_[0.0, np.linalg.norm(np.diff(xz, axis=0), axis=1) * FPS]

    speed, checked = speeds(perf), 0
    for verb in ("walk", "run"):
        alone = perform(graph, [], seconds=4.0, seed=seed, start=verb, adverbs=adverbs, stay=True)
        own = speeds(alone)[30:][alone.verb[30:] == graph.verb_index(verb)].min()
        loop = graph.loop(graph.verb_index(verb))
        inside = np.flatnonzero(perf.active == loop)
        checked += len(inside)
        assert speed[inside].min() >= 0.5 * own, (verb, speed[inside].min(), own)
    assert checked > 30, checked


def test_a_stop_begun_as_the_walk_rolls_a_foot_off_keeps_it_up(graphs):
    """A stop whose blend begins as the walk rolls a foot off, which the stand holds too: the planter had let the
    foot go (the walk lifts its ball), and the blend gave it the stand's swing lift, none, so it dropped to the floor
    for a frame while the walk carried it on (a toe 44 mm across the floor, 23 past the walk's own: the script of
    ``benchmarks/edges.py`` at seed 3). It now keeps the lift of the verb rolling it off."""
    graph = graphs["bandai"]
    script = [(0.5, "walk"), (3.5, "run"), (6.5, "walk"), (9.0, "idle"), (11.0, "reach"), (15.0, "bow"),
              (16.5, {"valence": 0.8}), (20.0, "guide"), (24.0, "bye"), (28.0, "walk"), (31.0, "idle")]  # fmt: skip
    adverbs = {"valence": -0.3, "energy": 0.2}
    cues = [Cue(t, adverbs=v) if isinstance(v, dict) else Cue(t, v) for t, v in script]
    perf = perform(graph, cues, seconds=34.0, seed=3, adverbs=adverbs, start="idle")
    names = graph.skeleton.names
    toes = [names.index("Toes_L"), names.index("Toes_R")]
    pos = perf.planted.global_positions()[:, toes]
    contact = _contact(pos)
    points = _points_in_effect(adverbs, script, perf.eases)
    owns = [_own(graph, "walk", toes, 3, p)["toe"] for _, _, p in points]
    stops = _windows(perf, graph, {("walk", "idle")})
    assert len(stops) >= 2, stops  # the one at 24.9 s begins as the walk rolls the right foot off
    for _, _, a, b in stops:
        own = max(o for (start, end, _), o in zip(points, owns) if start <= b / FPS and a / FPS < end)
        travel = low_travel(pos, contact, np.arange(a, b))
        assert travel <= own + 0.02, (a / FPS, travel, own)


@pytest.mark.parametrize("seed", [3, 5, 7])
def test_the_cmu_run_at_its_default_point_keeps_its_legs_under_it(graphs, seed):
    """At the CMU graph's default point (3.0 m/s, straight) the run played one example, the first cycle of 16_55,
    whose runner speeds up from 2.2 to 4.2 m/s within it. Made a cycle, its hips ran at 1.2-4.2 m/s around each loop:
    the body surged at every loop and left the stance foot 40 cm behind, and the legs flung it up to 29 cm over where
    the run has it (root acceleration 36 m/s²). The spec now plays steady cycles there: no toe is held more than
    10 cm over where the run has it.

    And the first frame of a run after a walk → run went at the blended verbs' velocity, which lagged the speed the
    blend had carried the body at: 3.0, then 2.3, then 3.3 m/s (29 m/s²). Wherever the run plays alone or loops into
    itself, its body root now accelerates at most 1.5x as three cycles of the run synthesized at the point do."""
    graph = graphs["cmu"]
    run = graph.verb_index("run")
    perf = perform(graph, [], seconds=6.0, seed=seed, start="run", stay=True)
    running = np.flatnonzero((perf.verb == run) & ((perf.active < 0) | (perf.active == graph.loop(run))))
    running = running[running > 30]
    assert len(running) > 30, "the run did not play"
    names = graph.skeleton.names
    toes = [names.index("ltoes"), names.index("rtoes")]
    planted, free = perf.planted.global_positions(), perf.free.global_positions()
    raised = (planted[running][:, toes, 1] - free[running][:, toes, 1]).max()
    assert raised <= 0.10, raised
    verb = graph.verbs[run]
    clip, _ = verb.synthesize(graph.verb_points(run, graph.point({})[None])[0], cycles=3, fps=30.0)
    xz = clip.global_positions()[:, verb.encoding.body_root][:, [0, 2]]
    own = np.linalg.norm(np.diff(np.diff(xz, axis=0), axis=0), axis=1).max() * FPS * FPS
    acc = _root_acceleration(perf, graph)
    assert acc[running].max() <= 1.5 * own, (acc[running].max(), own)


@pytest.mark.parametrize("seed", [1, 8, 9, 10, 12])
def test_an_adverb_cue_eases_as_long_as_it_needs(graphs, seed):
    """A valence cue in a bye, a stand, a walk, a bow and a guide (random points and times: the seeds of a sweep of
    20 where a half-second ease went over): through the ease and half a second after, no part turns faster than
    1.5x its fastest in the verbs played alone at either point. Over half a second they went to 4.2x (the bye's
    legs), 7.6x (the stand's trunk), 1.8x (the walk's arms), 1.9x and 2.0x (the bow's and the guide's trunk); by
    default each now eases as long as it needs (0.5 to 3 s: ``easing.ease_length``)."""
    graph = graphs["bandai"]
    toes = [graph.skeleton.names.index(n) for n in SCRIPTS["bandai"][2]]
    rng = np.random.default_rng(seed)
    verb = ["bow", "bye", "guide", "idle", "walk"][seed % 5]
    v0, v1 = rng.uniform(-1, 1), rng.uniform(-1, 1)
    at = rng.uniform(0.3, 2.0)
    own = [_own(graph, v, toes, 5, {"valence": float(x)}) for x in (v0, v1) for v in {verb, "idle"}]

    def fastest(ease):
        perf = perform(graph, [Cue(at, adverbs={"valence": float(v1)})], seconds=at + 3.6, seed=seed, start=verb,
                       adverbs={"valence": float(v0)}, stay=True, ease=ease)  # fmt: skip
        speed = _angular_speed(perf.planted.rotations)[int(at * FPS) - 1 :]
        return perf, {p: float(speed[:, j].max()) / max(o[p] for o in own) for p, j in _parts(graph).items()}

    perf, ratio = fastest(None)
    assert 0.5 <= perf.eases[0][1] <= 3.0
    assert max(ratio.values()) <= 1.5, (perf.eases, ratio)
    _, half_second = fastest(0.5)
    assert max(half_second.values()) > 1.5, half_second


@pytest.mark.parametrize("seed, adverbs", POINTS["bandai"])
def test_a_creature_standing_a_minute_stays_where_it_stands(graphs, seed, adverbs):
    """A minute of standing after a stop: the stand loops into itself, and each loop took on its take's travel and
    turn, so the body crept off its held feet 0.3-0.6 cm a second and turned about 1° a second (its hips 37-57° from
    its feet after a minute), and a foot stepped after it every 10-20 s from about half a minute on. The stand is
    in place now (``in_place``): read off the frames, from 6 s on the hips do not move across the floor or turn,
    and both feet stay held."""
    graph = graphs["bandai"]
    perf = perform(graph, [Cue(0.5, "walk"), Cue(3.0, "idle")], seconds=63.0, seed=seed, adverbs=adverbs, start="idle", stay=True)
    names = graph.skeleton.names
    pos = perf.planted.global_positions()[int(6 * FPS) :]
    hips = pos[:, names.index("Hips")]
    side = pos[:, names.index("UpperLeg_L")] - pos[:, names.index("UpperLeg_R")]
    turn = np.degrees(np.unwrap(np.arctan2(side[:, 2], side[:, 0])))
    assert np.ptp(hips[:, 0]) <= 0.005 and np.ptp(hips[:, 2]) <= 0.005, (np.ptp(hips[:, 0]), np.ptp(hips[:, 2]))
    assert np.ptp(turn) <= 0.5, np.ptp(turn)
    held = _held(perf)
    assert held[int(6 * FPS) :].all(), np.flatnonzero(~held[int(6 * FPS) :].all(axis=1))[:5] / FPS + 6


@pytest.mark.parametrize("seed", [502, 516, 519])
def test_a_runs_first_landing_after_a_walk_comes_down_at_the_runs_level(graphs, seed):
    """A swinging foot is lowered by its verb's contact level, which the planter takes as the foot leaves the floor in
    that verb: a creature's first stance in a verb had none, so the first CMU run after a walk landed its first feet
    with the walk's (at 2.8 m/s −5 mm where the run's own is −28): they came down 2 cm early and ran along the floor
    (116 mm of low travel in the tests' script, the run's own 84). A verb's level is now worked out from the verb at
    the creature's adverbs before the creature first plays it (``Verb.contact_levels``, ``planted.know_levels``):
    over the first walk → run of these random points (from the frame before the blend to half a second after it), a
    low toe travels no further than the verbs' own plus 2 cm: 27, 57 and 38 mm, the old code's 83, 150 and 87 (its
    bounds 103, 145 and 70). (Seed 518 travels 152 mm against a bound of 133 either way: not this.)"""
    rng = np.random.default_rng(seed)
    adverbs = {"walk_speed": float(rng.uniform(0.9, 1.7)), "run_speed": float(rng.uniform(2.2, 4.0)),
               "turn": float(rng.uniform(-35, 35))}  # fmt: skip
    graph = graphs["cmu"]
    perf = perform(graph, [Cue(0.5, "walk"), Cue(2.0, "run")], seconds=5.0, seed=seed, adverbs=adverbs, start="walk", stay=True)
    names = graph.skeleton.names
    toes = [names.index(n) for n in ("ltoes", "rtoes")]
    pos = perf.planted.global_positions()[:, toes]
    _, _, a, b = next(w for w in _windows(perf, graph, {("walk", "run")}))
    own = max(_own(graph, v, toes, seed, adverbs)["toe"] for v in ("walk", "run"))
    shown = low_travel(pos, _contact(pos), np.arange(a, b))
    assert shown <= own + 0.02, f"{shown * 1000:.0f} mm, the verbs' own {own * 1000:.0f}"


def _standing_script(seed: int):
    """A random script of the four Bandai gestures in a random order, a stand asked for 3-5 s after each, the next
    gesture 1-2.5 s later, at a random valence: ``(cues, seconds, toe names, kinds)`` and its adverbs."""
    rng = np.random.default_rng(seed)
    t, cues = 0.5, []
    for gesture in rng.permutation(["reach", "bow", "guide", "bye"]):
        cues.append((round(t, 2), str(gesture)))
        t += rng.uniform(3.0, 5.0)
        cues.append((round(t, 2), "idle"))
        t += rng.uniform(1.0, 2.5)
    adverbs = {"valence": float(rng.uniform(-1.0, 1.0)), "energy": 0.0, "turn": 0.0}
    return (cues, t + 2.0, ("Toes_L", "Toes_R"), set()), adverbs


@pytest.mark.parametrize("seed", [104, 107, 101])
def test_a_blend_between_standing_verbs_turns_no_part_faster_than_its_verbs(graphs, seed):
    """A blend from one standing verb into another (a stand into a gesture, a gesture into the stand) lasted the mean
    of its regions, however far apart the two verbs hold a joint: a sad stand holds its head 25° from a sad bow's, and
    the bow turned the head at 3.5x the verbs' own fastest (seed 104, valence -0.87; 2.2x at seed 107). Such a blend
    now lasts long enough that, by its blending alone, no part but the legs turns faster than the part's own fastest
    in the two verbs (``clocks.paced_length``; the legs are the planter's), up to 2 s; a command that cuts a stand's
    loop short blends into the gesture so too, where it decayed onto it at once. Every window between standing verbs
    keeps its arms and trunk within 1.5x their verbs' own. Random scripts (seeds 100-107 drawn, not tuned on: these
    failed before, 101 passed); the fixed script's windows: :func:`test_every_transition_keeps_its_joints_and_root`."""
    script, adverbs = _standing_script(seed)
    standing = {"idle", "reach", "bow", "guide", "bye"}
    failures, windows = [], 0
    for s, t, a, _, shown, ref in _played(graphs["bandai"], f"standing {seed}", seed, adverbs, script):
        if s in standing and t in standing and s != t:
            windows += 1
            for what in ("arms", "trunk"):
                if shown[what] > 1.5 * ref[what]:
                    failures.append(f"{s}→{t} at {a / FPS:.2f} s: {what} at {shown[what] / ref[what]:.2f}x its verbs' own")
    assert windows >= 8, windows
    assert not failures, "\n".join(failures)


@pytest.mark.parametrize("verb", ["idle", "bow", "guide", "bye"])
def test_a_verbs_own_part_speeds_are_what_its_poses_show(graphs, verb):
    """How fast a verb turns each part at a creature's adverbs, and moves its hips over its feet, as blends between
    standing verbs are paced by (``Graph.own_speeds``: its examples' joint and body speeds blended with the creature's
    weights at each generic time, their fastest) is 0.67-1.37x the fastest its poses there show, sampled 16 times
    finer, at valences across its span (the sad bow's trunk 1.03x, where its examples' fastest blended, not their
    speeds through time, said 1.4x); at an example's own weights it is that example's."""
    from adverbs.interp.timewarp import clock_time
    from adverbs.kinematics.fk import forward_kinematics
    from adverbs.verb.sampling import dofs
    from adverbs.verb.tables import body_place

    graph = graphs["bandai"]
    v = graph.verb_index(verb)
    own_verb = graph.verbs[v]
    one_hot = np.eye(len(own_verb.examples))
    for e in range(len(one_hot)):
        np.testing.assert_allclose(graph.own_speeds(v, one_hot[e]), graph.part_speeds[v][e], rtol=0, atol=1e-12)
    g = np.linspace(0.0, 1.0, 16 * 64 + 1)
    for valence in (-0.9, -0.5, 0.2, 0.6):
        p = graph.verb_points(v, graph.point({"valence": valence})[None])[0]
        rot, trans = own_verb.encoding.decode_pose(dofs(own_verb, np.tile(p, (len(g), 1)), g), np.zeros((len(g), 3)))
        seconds = np.diff(clock_time(g, own_verb.keytimes(p), own_verb.generic_keytimes))
        speed = _angular_speed(rot) / FPS / seconds[:, None]  # (rad between samples, per second of the verb's clock)
        place = body_place(own_verb.encoding, forward_kinematics(own_verb.skeleton.parents, rot, trans)[0])
        body = np.linalg.norm(np.diff(place, axis=0), axis=-1) / seconds  # the hips over the feet
        shown = np.array([*(speed[:, part].max() for part in graph.paced), body.max()])
        ratio = graph.own_speeds(v, own_verb.weights(p)) / shown
        assert np.all((ratio > 0.6) & (ratio < 1.4)), (valence, ratio)
