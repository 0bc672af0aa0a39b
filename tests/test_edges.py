"""Motion at the edges of verbs (issue 32), measured on the frames a performance writes, never on the planter's state.

A foot low on the floor must not travel: at a stop the swinging foot lands where it is (it used to skid 23-57 cm
along the floor), at a start the first foot lifts before it travels (it dragged 11-15 cm backwards). The bound is
the walk's own: a toe pivoting on its ball moves a few centimetres while low in the capture too, so a transition
may move a low toe as far as the walk alone does, plus 2 cm. An adverb cue during a gesture eases in instead of
snapping the pose in one frame.

The scripts and adverb points here are not the ones the changes were tuned on (the report's runs A, B and C).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from adverbs import load_graph
from adverbs.errors import AdverbsWarning
from adverbs.graph.performance import Cue, perform
from adverbs.kinematics import quat

GRAPHS = Path(__file__).resolve().parent.parent / "graphs"
LOW = 0.02  # metres over the toe's contact height: "on the floor"
MOVING = 0.001  # metres a frame: a toe that moves less is still (a way along the floor does not go on in such frames)
FPS = 30.0
PARTS = {  # the parts of a body whose joints' speeds are held to their verbs' own, by what their joints' names hold
    "arms": ("shoulder", "arm", "hand", "humerus", "radius", "wrist", "clavicle", "finger", "thumb"),
    "legs": ("leg", "foot", "toe", "femur", "tibia"),
    "trunk": ("hips", "spine", "chest", "neck", "head", "back", "thorax"),
}


def _parts(graph):
    """The joints of each part of the body (:data:`PARTS`), by name."""
    names = [n.lower() for n in graph.skeleton.names]
    return {p: [i for i, n in enumerate(names) if any(k in n for k in keys)] for p, keys in PARTS.items()}


@pytest.fixture(scope="module")
def bandai():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        return load_graph(GRAPHS / "bandai.toml")


def _toes(graph):
    names = graph.skeleton.names
    return [names.index(n) for n in ("Toes_L", "Toes_R")]


def low_travel(positions: np.ndarray, contact: np.ndarray, frames: np.ndarray, within: tuple | None = None) -> float:
    """The longest way (m) a toe goes across the floor over consecutive ``frames`` while within :data:`LOW` of its
    contact height: ``positions (F, T, 3)`` of T toes, ``contact (T,)``. ``within (a, b)``: only ways that go on
    (by :data:`MOVING` or more a frame) in frames ``a`` to ``b`` count, each whole: a part of a window
    (:func:`_settled`) is charged with the ways that cross it, not with a step that landed before it began (a stop's
    foot re-placed in the stop's settling half second, held still through the gesture after it)."""
    best = 0.0
    for i in range(positions.shape[1]):
        travel, counts = 0.0, within is None
        for f in frames:
            if f == 0:
                continue
            if positions[f, i, 1] - contact[i] < LOW:
                step = float(np.hypot(*(positions[f, i, [0, 2]] - positions[f - 1, i, [0, 2]])))
                travel += step
                counts = counts or (within[0] <= f < within[1] and step >= MOVING)
                if counts:
                    best = max(best, travel)
            else:
                travel, counts = 0.0, within is None
    return best


def _windows(perf, graph, pairs):
    """Frames ``(a, b)`` of every transition of ``perf`` whose (source, target) names are in ``pairs``, with the
    frames after it until the next transition (at most half a second), where a landing settles."""
    names = graph.verb_names
    out, f = [], 0
    active = perf.active
    while f < len(active):
        if active[f] < 0:
            f += 1
            continue
        k, a = active[f], f
        while f < len(active) and active[f] == k:
            f += 1
        t = graph.transitions[k]
        if (names[t.source], names[t.target]) in pairs:
            end = f
            while end < min(len(active), f + int(FPS / 2)) and active[end] < 0:
                end += 1
            out.append((names[t.source], names[t.target], a, end))
    return out


def _settled(perf, graph, windows):
    """``windows`` ``(source, target, a, b)`` in order, each with the verbs it is measured against besides its own
    and which of ``windows`` it is part of: ``(source, target, a, b, verbs, k)``.

    A transition's window runs on for half a second after it ends, where its landing settles, unless the next
    transition starts first; the frames of that half second later windows take are the earlier transition's landing
    still, and are measured against its verbs as well (parts of their own, named as the later window's). Until
    session 58 only the window just before was taken so: a Bandai stand loops into itself every 0.3 s, so a stop's
    half second held the first of its loops and not the second, where a foot the stop re-placed landed (6.6x the
    stand's own legs, the walk's own not counted). What a frame shows (a joint's speed, the root's acceleration) is
    measured part by part; what a span shows over the whole window: the hips' range, and a toe's ways along the
    floor, each whole, charged to the parts it goes on in (``low_travel(within=...)``; until session 58 the whole
    window's longest way was charged to every part, so a stop's step landing in its half second counted against the
    gesture after it as well). (Every Bandai stop blends into the whole stand, which is then at its end and past the
    start of its loop's region: the stand's loop into itself starts the frame after the stop ends. The stop's
    trailing foot, let go once the other has landed, lands in it 0.2-0.3 s later, its knee at 230 deg/s where the
    stand's own legs turn at 10: against the stand alone, 22x.)"""
    out, landings = [], []  # (the frame its half second ends, its verbs) of every window before
    for k, (s, t, a, b) in enumerate(windows):
        cuts = sorted({a, b} | {u for u, _ in landings if a < u < b})
        for lo, hi in zip(cuts[:-1], cuts[1:]):
            out.append((s, t, lo, hi, set().union(*(v for u, v in landings if u > lo)), k))
        # (its own half second counted from where the one just before ends in it, if it does: as until session 58)
        start = min(landings[-1][0], b) if landings and a < landings[-1][0] else a
        end = start
        while end < len(perf.active) and perf.active[end] >= 0 and perf.active[end] == perf.active[start]:
            end += 1
        landings.append((end + int(FPS / 2), {s, t}))
    return out


def _contact(positions):
    return np.percentile(positions[:, :, 1], 1, axis=0)


def _begins(graph, perf, source: str | None, target: str) -> int:
    """The first frame of ``perf`` at which a transition from verb ``source`` (any: None) into ``target`` begins."""
    begins = np.flatnonzero((perf.active >= 0) & (np.r_[-1, perf.active[:-1]] != perf.active))
    t = graph.transitions
    want = (None if source is None else graph.verb_index(source), graph.verb_index(target))
    return next(f for f in begins if (want[0] in (None, t[perf.active[f]].source)) and t[perf.active[f]].target == want[1])


@pytest.mark.parametrize(
    "seed, adverbs",
    [(5, {"valence": 0.2, "energy": 0.3, "turn": 10.0}), (8, {"valence": -0.6, "energy": -0.4, "turn": -25.0}), (13, {})],
)
def test_stops_land_the_swinging_foot_and_starts_lift_the_first(bandai, seed, adverbs):
    cues = [Cue(t, v) for t, v in [(0.3, "walk"), (4.1, "idle"), (6.7, "walk"), (10.2, "idle"), (12.9, "walk"), (16.4, "idle")]]
    perf = perform(bandai, cues, seconds=19.0, seed=seed, adverbs=adverbs)
    toes = _toes(bandai)
    pos = perf.planted.global_positions()[:, toes]
    contact = _contact(pos)
    # The walk's own: the same measure over three of its cycles alone, at the same adverbs.
    alone = perform(bandai, [Cue(0.0, "walk")], seconds=8.0, seed=seed, adverbs=adverbs)
    walking = np.flatnonzero((alone.active < 0) & (alone.verb == bandai.verb_index("walk")))
    own_pos = alone.planted.global_positions()[:, toes]
    own = low_travel(own_pos, _contact(own_pos), walking[walking > 90])
    windows = _windows(perf, bandai, {("walk", "idle"), ("idle", "walk")})
    kinds = {(s, t) for s, t, _, _ in windows}
    assert kinds == {("walk", "idle"), ("idle", "walk")}, f"the script should stop and start the walk: {windows}"
    failures = []
    for s, t, a, b in windows:
        travel = low_travel(pos, contact, np.arange(a, b))
        if travel > own + 0.02:
            failures.append(f"{s}→{t} at {a / FPS:.2f} s: a low toe travels {travel * 1000:.0f} mm (the walk's own {own * 1000:.0f})")
    assert not failures, "\n".join(failures)


@pytest.mark.parametrize(
    "seed, adverbs, times",
    [
        (20, {"valence": 0.6699632610040178, "energy": 0.19310805393577457, "turn": -12.668205498527783},
         [1.5859031413884228, 5.033211931600851, 7.726155339730228, 10.80668166856767, 14.127360431158575,
          17.003669326342067, 18.883652273117512, 22.346610234372044]),
        (23, {"valence": 0.3122340542452533, "energy": -0.97064793942922, "turn": 20.07193031897183},
         [1.6447981560969176, 4.193039802698613, 6.786140833759461, 8.740634759026419, 12.152591191684275,
          14.334518893334343, 16.8439337747489, 20.07870099785009]),
    ],
)  # fmt: skip
def test_a_stop_that_re_places_the_rolling_foot_keeps_it_swinging(bandai, seed, adverbs, times):
    """A stop whose stand has the walk's rolling foot elsewhere re-places that foot as it rolls off. The re-placed
    foot came down as it neared where the verbs have it, but there the walk swings it and the blend with the stand
    draws it along the floor: its toe skidded 6-17 cm past the walk's own (here 65 and 56 mm over at these points;
    benchmarks/edges.py found it at another). It now comes down no lower than the walk's own swing lifts it.

    The points and cue times are those of a random sweep of stops and starts (a walk or a stand every 1.5-3.5 s),
    replayed exactly: the skid needs the feet as the stops and starts before left them. Every stop is measured, those
    a walk cue turns back into the walk too (seed 20 at 18.88 s, seed 23 at 6.79 s): turned back, the stop's landing
    foot got the walk's hold past its heel-off while still in the air, lost the least swing lift and dropped 20 mm in
    a frame, skimming on at the walk's pace (55 and 73 mm, the walk's own 25 and 17); a foot its verbs hold past
    heel-off while in the air is lifting, and keeps the lift (24 and 35 mm)."""
    cues = [Cue(t, v) for t, v in zip(times, ["walk", "idle"] * 4)]
    perf = perform(bandai, cues, seconds=times[-1] + 2.5, seed=seed, adverbs=adverbs, start="idle")
    toes = _toes(bandai)
    pos = perf.planted.global_positions()[:, toes]
    alone = perform(bandai, [], seconds=6.0, seed=seed, start="walk", adverbs=adverbs, stay=True).planted.global_positions()[:, toes]
    own = low_travel(alone, _contact(alone), np.arange(30, len(alone)))
    stops = _windows(perf, bandai, {("walk", "idle")})
    assert len(stops) >= 4, stops
    contact = _contact(pos)
    worst = max(low_travel(pos, contact, np.arange(a, b)) for _, _, a, b in stops)
    assert worst <= own + 0.02, (worst, own)


def _angular_speed(rotations: np.ndarray) -> np.ndarray:
    """Each joint's angular speed between frames ``(F − 1, J)``, rad/s."""
    q = quat.mul(rotations[1:], quat.inv(rotations[:-1]))
    return 2.0 * np.arccos(np.clip(np.abs(q[..., 3]), 0.0, 1.0)) * FPS


def test_an_adverb_cue_during_a_gesture_eases_in(bandai):
    """``16:valence=0.9`` during a sad bow turned a hand 1,320 deg/s in one frame; eased (by default as long as the
    change needs, at least half a second: ``easing.ease_length``) it stays within 1.5x the bow's own fastest joint
    (the bow alone, at either valence). Each part against its own: ``test_transitions``'s cue windows."""
    bow = [Cue(2.0, adverbs={"valence": 0.9})]
    own = max(
        _angular_speed(perform(bandai, [], seconds=3.5, start="bow", adverbs={"valence": v}, stay=True).planted.rotations).max()
        for v in (-0.8, 0.9)
    )
    cue = int(2.0 * FPS)
    eased = perform(bandai, bow, seconds=3.5, start="bow", adverbs={"valence": -0.8})
    assert eased.playing[cue].startswith("bow"), eased.playing[cue]
    fastest = _angular_speed(eased.planted.rotations)[cue - 2 : cue + 30].max()
    assert fastest <= 1.5 * own, (np.degrees(fastest), np.degrees(own))
    # At once (ease=0), as it was: the cue snaps the pose, which this test would see.
    snapped = perform(bandai, bow, seconds=3.5, start="bow", adverbs={"valence": -0.8}, ease=0.0)
    assert _angular_speed(snapped.planted.rotations)[cue - 2 : cue + 30].max() > 1.5 * own


def _own(graph, verb, adverbs, seconds):
    """A verb's own fastest arm joint (rad/s), planted, played alone from its start."""
    rotations = perform(graph, [], seconds=seconds, start=verb, adverbs=adverbs, stay=True).planted.rotations
    return _angular_speed(rotations)[:, _parts(graph)["arms"]].max()


@pytest.mark.parametrize("seed", [4, 9])
def test_a_gesture_begun_from_a_stand_cut_short_moves_no_faster_than_its_own(bandai, seed):
    """A gesture asked for while the stand plays starts at its own start and plays no faster than its own clock: it
    used to start part-way through its raise in a 0.13-0.23 s blend, an arm at 2.2-2.3x the reach's own fastest
    (here, before: up to 2.0x; now at most 1.21x)."""
    rng = np.random.default_rng(seed)
    adverbs = {"valence": float(rng.uniform(-0.5, 0.5))}
    times = np.cumsum(rng.uniform(2.5, 4.5, 8))
    cues = [Cue(float(t), str(v)) for t, v in zip(times, ["reach", "bow", "reach", "guide"] * 2)]
    perf = perform(bandai, cues, seconds=float(times[-1] + 4.0), seed=seed, adverbs=adverbs)
    speed = _angular_speed(perf.planted.rotations)[:, _parts(bandai)["arms"]].max(axis=1)
    own = {v: _own(bandai, v, adverbs, 6.0) for v in ("idle", "reach", "bow", "guide")}
    entries = _windows(perf, bandai, {("idle", g) for g in ("reach", "bow", "guide")})
    assert len(entries) >= 4, entries
    failures = [
        f"idle→{t} at {a / FPS:.2f} s: an arm at {np.degrees(speed[max(a - 1, 0) : b].max()):.0f} deg/s, its verbs' "
        f"own {np.degrees(max(own['idle'], own[t])):.0f}"
        for _, t, a, b in entries
        if speed[max(a - 1, 0) : b].max() > 1.5 * max(own["idle"], own[t])
    ]
    assert not failures, "\n".join(failures)


@pytest.mark.parametrize("seed, adverbs", [(6, {"valence": 0.3, "energy": 0.2}), (12, {"valence": -0.4, "energy": 0.5})])
def test_a_run_slows_into_a_walk_without_stopping(bandai, seed, adverbs):
    """Run → walk: the hips slowed to 0.06-0.33 m/s inside every blend, then lurched on (the body was carried by a
    stance foot the walk puts further ahead). Now it goes at the blend of the two verbs' speeds: never slower than
    half the walk's own slowest, and never faster than the run's own fastest."""
    cues = [Cue(t, v) for t, v in [(0.3, "walk"), (2.5, "run"), (6.0, "walk"), (9.0, "run"), (12.5, "walk")]]
    perf = perform(bandai, cues, seconds=15.0, seed=seed, adverbs=adverbs)
    hips = bandai.skeleton.names.index("Hips")

    def speeds(p):
        xz = p.planted.global_positions()[:, hips][:, [0, 2]]
        return np.r_[0.0, np.linalg.norm(np.diff(xz, axis=0), axis=1) * FPS]

    own = {}
    for verb in ("walk", "run"):
        alone = perform(bandai, [], seconds=4.0, seed=seed, start=verb, adverbs=adverbs, stay=True)
        own[verb] = speeds(alone)[30:]
    speed = speeds(perf)
    names = bandai.verb_names
    slowing = [k for k, t in enumerate(bandai.transitions) if (names[t.source], names[t.target]) == ("run", "walk")]
    inside = np.isin(perf.active, slowing)  # the blends themselves
    assert inside.sum() > 10, "the run never slowed into a walk"
    assert speed[inside].min() >= 0.5 * own["walk"].min(), (speed[inside].min(), own["walk"].min())
    assert speed[inside].max() <= own["run"].max() + 0.05, (speed[inside].max(), own["run"].max())


@pytest.fixture(scope="module")
def cmu():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        return load_graph(GRAPHS / "cmu.toml")


@pytest.mark.parametrize("seed, adverbs", [(3, {}), (7, {"walk_speed": 1.3, "turn": 20.0})])
def test_the_cmu_walk_and_run_blend_on_their_feet_without_braking(cmu, seed, adverbs):
    """The other skeleton, both ways between walk and run: no low toe travels 2 cm further than the verbs' own do
    (the CMU capture's own toes skate 2-17 cm while low), and the pelvis never slows below half the walk's slowest."""
    names = cmu.skeleton.names
    toes, pelvis = [names.index(n) for n in ("ltoes", "rtoes")], names.index("pelvis")
    cues = [Cue(t, v) for t, v in [(0.3, "walk"), (3.0, "run"), (6.0, "walk"), (9.0, "run"), (12.0, "walk")]]
    perf = perform(cmu, cues, seconds=15.0, seed=seed, adverbs=adverbs)
    pos = perf.planted.global_positions()
    own_travel, own_slowest = 0.0, np.inf
    for verb in ("walk", "run"):
        alone = perform(cmu, [], seconds=5.0, seed=seed, start=verb, adverbs=adverbs, stay=True).planted.global_positions()
        own_travel = max(own_travel, low_travel(alone[:, toes], _contact(alone[:, toes]), np.arange(30, len(alone))))
        if verb == "walk":
            own_slowest = (np.linalg.norm(np.diff(alone[30:, pelvis][:, [0, 2]], axis=0), axis=1) * FPS).min()
    speed = np.r_[np.inf, np.linalg.norm(np.diff(pos[:, pelvis][:, [0, 2]], axis=0), axis=1) * FPS]
    windows = _windows(perf, cmu, {("walk", "run"), ("run", "walk")})
    assert {(s, t) for s, t, _, _ in windows} == {("walk", "run"), ("run", "walk")}, windows
    for s, t, a, b in windows:
        travel = low_travel(pos[:, toes], _contact(pos[:, toes]), np.arange(a, b))
        assert travel <= own_travel + 0.02, (s, t, a / FPS, travel, own_travel)
        assert speed[a:b].min() >= 0.5 * own_slowest, (s, t, a / FPS, speed[a:b].min(), own_slowest)


def _run_low_travel(graph, point, seed: int = 1) -> float:
    """The furthest a toe of the CMU run, played alone at ``point = (run_speed, turn)``, travels low on the floor."""
    perf = perform(graph, [], seconds=5.0, seed=seed, start="run", adverbs={"run_speed": point[0], "turn": point[1]}, stay=True)
    toes = [graph.skeleton.names.index(n) for n in ("ltoes", "rtoes")]
    pos = perf.planted.global_positions()[:, toes]
    return low_travel(pos, _contact(pos), np.arange(30, len(pos)))


@pytest.mark.parametrize("point", [
    pytest.param((4.14, 42.9), marks=pytest.mark.xfail(strict=True, reason=(
        "issue 32: with its examples played alone (staying, not wandering into the walk) their toes travel 161 mm "
        "low, this point's 210"))),
    (3.51, 20.6), (3.84, 28.1)])  # fmt: skip
def test_the_cmu_run_between_its_examples_lands_its_feet_as_they_do(cmu, point):
    """Between its examples, the run's feet come down as the examples it blends do: no low toe travels 2 cm further
    than the furthest of theirs (each example played alone at its own point, those weighing at least 0.1). A blend of
    the examples' leg rotations swung the feet lower than any of them (3 cm lower through the landing at 3.6 m/s
    turning 30°/s): the toes came in low and fast and skidded 33-36 cm at these points (now 12-15), against the
    examples' 21 cm.
    The points are drawn at random inside the examples' box (seed 11); nothing was tuned on them."""
    verb = cmu.verbs[cmu.verb_index("run")]
    weights = verb.weights(np.array(point))
    own = max(_run_low_travel(cmu, verb.points[e]) for e in np.flatnonzero(weights >= 0.1))
    travel = _run_low_travel(cmu, point)
    assert travel <= own + 0.02, f"a low toe travels {travel * 1000:.0f} mm (its examples' {own * 1000:.0f})"


def test_the_examples_lift_is_each_examples_own_at_its_point(cmu):
    """At an example's own point (one-hot weights) the examples' lift of each foot is that example's own: its feet's
    heights over their contact heights, FK of the verb's DOFs there, to rounding at the table's samples and within
    the planter's slack between them (so the planter leaves an example as it is); on the cycle before, the same
    shifted by the seam as sampling shifts it."""
    from adverbs.feet.planter import EXAMPLE_SLACK, example_lifts
    from adverbs.kinematics.fk import forward_kinematics
    from adverbs.verb.tables import LIFT_SAMPLES

    verb = cmu.verbs[cmu.verb_index("run")]
    tips = [verb.skeleton.index(c.effector) for c in verb.constraints]
    heights = np.array([h.height for h in verb.holds])
    at_samples = np.arange(LIFT_SAMPLES) / LIFT_SAMPLES
    between = at_samples + 0.37 / LIFT_SAMPLES
    for e, p in enumerate(verb.points):
        one_hot = np.zeros((1, len(verb.examples)))
        one_hot[0, e] = 1.0
        for g, tol in ((at_samples, 1e-12), (between, EXAMPLE_SLACK)):
            rot, trans = verb.encoding.decode_pose(verb.dofs(np.tile(p, (len(g), 1)), g), np.zeros(3))
            own = forward_kinematics(verb.skeleton.parents, rot, trans)[0][:, tips, 1] - verb.floor - heights
            got = np.concatenate([example_lifts(verb, one_hot, np.array([t])) for t in g])
            np.testing.assert_allclose(got, own, rtol=0, atol=tol)
    # The cycle before: what the seam-shifted pose of a loop's entering verb has.
    shift = np.array(verb.seam_table[0])
    shift[:3] = 0.0
    g = np.array([0.25, 0.5])
    rot, trans = verb.encoding.decode_pose(verb.dofs(np.tile(verb.points[0], (2, 1)), g) - shift, np.zeros(3))
    own = forward_kinematics(verb.skeleton.parents, rot, trans)[0][:, tips, 1] - verb.floor - heights
    one_hot = np.eye(len(verb.examples))[:1]
    got = np.concatenate([example_lifts(verb, one_hot, np.array([t - 1.0])) for t in g])
    np.testing.assert_allclose(got, own, rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    "seed, adverbs",
    [(30, {"valence": 0.49, "energy": 0.49}), (38, {"valence": -0.17, "energy": -0.01}),
     (40, {"valence": 0.09, "energy": -0.37})],
)  # fmt: skip
def test_a_start_cut_short_by_a_command_speeds_up_as_the_walk_does(bandai, seed, adverbs):
    """A start (stand → walk) cut short two frames in by a command (a reach: back to the stand) carries the body no
    harder than the walk accelerates its own (at most 1.5x its root's fastest acceleration). The blend had held the
    body to its speed, along the walk's way, while the held foot's slip ran ahead; the interruption let the whole
    slip carry it at once, at its own speed and way: 0.07 to 0.37 m/s sideways in a frame, then forward, 11-15 m/s²
    against the walk's own 6.5-9.4 (1.6-1.7x here). Carried by its feet under the decaying offset, the body's velocity
    now changes no faster than its verbs' own bodies do (``player.carry_limits``). Seeds and points drawn at random
    (of 12 tried, 4 failed, these 3 by the most); nothing was tuned on them. Seed 40 stayed at 1.50x (6.40 m/s²
    against 6.38) while the limit blended each example's own acceleration, 6.40 there where the walk shows 4.25; the
    walk's own root velocities as a frame shows them say 4.10 (``Verb.carry_limit``): 0.96x."""
    from test_transitions import _root_acceleration

    plain = perform(bandai, [Cue(0.5, "walk")], seconds=8.0, seed=seed, adverbs=adverbs, start="idle")
    start = _begins(bandai, plain, None, "walk")
    cut = (start + 2) / FPS  # the frame shown at time f / FPS is frame f - 1 (frames start at dt)
    perf = perform(bandai, [Cue(0.5, "walk"), Cue(cut, "reach")], seconds=8.0, seed=seed, adverbs=adverbs,
                   start="idle")  # fmt: skip
    assert perf.active[start] == plain.active[start] and perf.active[start + 2] != plain.active[start + 2], (
        "the command should cut the start short two frames in"
    )
    own = _root_acceleration(perform(bandai, [], seconds=6.0, seed=seed, start="walk", adverbs=adverbs, stay=True), bandai)[30:].max()
    acc = _root_acceleration(perf, bandai)[start : start + 15]
    assert acc.max() <= 1.5 * own, f"{acc.max():.1f} m/s² at {(start + int(np.argmax(acc))) / FPS:.2f} s (the walk's own {own:.1f})"


def gesture_script(seed: int):
    """A random script of stands, gestures and walks (cues every 0.6-4 s for 26 s) and its adverbs."""
    rng = np.random.default_rng(seed)
    adverbs = {"valence": float(rng.uniform(-0.6, 0.6)), "energy": float(rng.uniform(-0.4, 0.4))}
    t, cues = 0.3, []
    while t < 26:
        cues.append(Cue(round(t, 3), str(rng.choice(["idle", "reach", "bow", "guide", "bye", "walk", "idle", "bow", "guide"]))))
        t += float(rng.uniform(0.6, 4.0))
    return cues, adverbs


@pytest.mark.parametrize("seed", [104, 300])
def test_a_gesture_asked_for_late_in_a_stand_blends_as_long_as_one_asked_for_at_its_start(bandai, seed):
    """The stand's way into the guide is open over the whole stand, and the blend lasts the mean of the two regions.
    Asked for late in the stand, only what was left of its region went into that mean: near the stand's end the blend
    took 0.15 s, and the trunk turned at 1.9-2.1x its verbs' own fastest (here, and in 11 of 50 idle → guide windows
    of 30 random gesture scripts). It now lasts as long whenever it is asked for (the stand's clock runs slower
    through what is left of its region), and no trunk joint turns faster than 1.5x its verbs' own. Random scripts."""
    cues, adverbs = gesture_script(seed)
    perf = perform(bandai, cues, seconds=28.0, seed=seed, adverbs=adverbs, start="idle")
    speed = _angular_speed(perf.planted.rotations)[:, _parts(bandai)["trunk"]].max(axis=1)
    own = max(_angular_speed(perform(bandai, [], seconds=6.0, seed=seed, start=v, adverbs=adverbs, stay=True).planted.rotations)[1:, _parts(bandai)["trunk"]].max()
              for v in ("idle", "guide"))  # fmt: skip
    entries = _windows(perf, bandai, {("idle", "guide")})
    assert len(entries) >= 3, entries
    lengths = []
    for _, _, a, b in entries:
        frames = int(np.count_nonzero(perf.active[a:b] == perf.active[a]))
        cut = any(a / FPS <= cue.time < (a + frames) / FPS for cue in cues)  # a later command cut it short
        if perf.active[a - 1] < 0 and not cut:  # begun from the stand playing alone (not an interrupted blend: B at once)
            lengths.append(frames)
        fastest = speed[max(a - 1, 0) : b].max()
        assert fastest <= 1.5 * own, f"idle→guide at {a / FPS:.2f} s: the trunk at {fastest / own:.2f}x its verbs' own"
    assert len(lengths) >= 2 and max(lengths) - min(lengths) <= 1, lengths  # frames: one blend, whenever it began


@pytest.mark.parametrize("seed", [109, 116, 123])
def test_a_foot_let_go_out_of_reach_is_held_again_where_the_stand_holds_it(bandai, seed):
    """A walk's stance foot, left behind as a stop was cut short by a bow, was let go out of its leg's reach; the
    stand and the gestures hold it flat for as long as they play, and it stayed free until their hold ended, which
    never came: it followed the body along the floor, 60 cm at once, then 10 cm at each later gesture. It is now
    re-placed, a step to where they hold it. Random gesture scripts that walk: in every transition between standing
    verbs from a second after the last walk, no toe travels more than 2 cm along the floor. (Seed 106 of 30 tried at
    random was where it happened until session 55, when the gestures' blends were paced and its script stopped
    walking. These are scripts of seeds 100-124 that walk: 116 and 123, whose standing toes travel furthest, 15 and
    14 mm, and 109; whether a foot is let go out of reach in them was not checked.)"""
    cues, adverbs = gesture_script(seed)
    perf = perform(bandai, cues, seconds=28.0, seed=seed, adverbs=adverbs, start="idle")
    pos = perf.planted.global_positions()[:, _toes(bandai)]
    contact = _contact(pos)
    standing = ("idle", "reach", "bow", "guide", "bye")
    walked = np.flatnonzero(perf.verb == bandai.verb_index("walk"))
    entries = [(s, t, a, b) for s, t, a, b in _windows(perf, bandai, {(x, y) for x in standing for y in standing})
               if a - walked[walked < a].max(initial=-100) > FPS]  # fmt: skip
    assert len(walked) and len(entries) >= 8, entries
    for s, t, a, b in entries:
        travel = low_travel(pos, contact, np.arange(a, b))
        assert travel <= 0.02, f"{s}→{t} at {a / FPS:.2f} s: a toe travels {travel * 1000:.0f} mm along the floor"


@pytest.mark.parametrize("gesture", ["guide", "bow", "reach"])
def test_a_stop_asked_for_a_gesture_lands_its_feet_first(bandai, gesture):
    """A gesture asked for while a walk stops used to cut the stop short: the stand played at once from the pose
    shown, the body went on at the walk's (decaying) speed under it, and the swinging foot was put down where it
    was, fast: a toe 16-19 cm along the floor (seed 3, asked 0.335 s after the stop, of 135 stops scanned). The stop
    now runs to its end, its feet down, and the gesture follows: whenever in the stop it is asked for, no low toe
    travels more than the walk's own plus 2 cm."""
    seed = 3
    walk = perform(bandai, [Cue(0.0, "walk")], seconds=8.0, seed=seed)
    walking = np.flatnonzero((walk.active < 0) & (walk.verb == bandai.verb_index("walk")))
    own_pos = walk.planted.global_positions()[:, _toes(bandai)]
    own = low_travel(own_pos, _contact(own_pos), walking[walking > 90])
    for delay in (0.067, 0.2, 0.335, 0.47):
        cues = [Cue(0.3, "walk"), Cue(3.0, "idle"), Cue(3.0 + delay, gesture)]
        perf = perform(bandai, cues, seconds=7.0, seed=seed, start="idle")
        pos = perf.planted.global_positions()[:, _toes(bandai)]
        travel = low_travel(pos, _contact(pos), np.arange(85, len(pos)))
        assert travel <= own + 0.02, f"asked {delay:.3f} s into the stop: a low toe travels {travel * 1000:.0f} mm"
        assert bandai.verb_index(gesture) in perf.verb[int((3.0 + delay) * FPS) :], f"no {gesture} after the stop"


@pytest.mark.parametrize("seed", [316, 615])
def test_a_start_carries_the_upper_body_on_at_its_verbs_pace(bandai, seed):
    """A start (a stand into a walk) blends over 0.1-0.3 s, as its feet agree; a happy stand holds its chest and head
    where the walk's first steps do not, and the blend turned them at 1.5-1.7x the verbs' own fastest trunk joint (the
    head at 2.0 rad/s against the walk's 1.26; five of 150 random scripts of ``benchmarks/edges.py``, these two
    among them), an arm at 1.57x in another. A start now plays the walk's upper body (``Graph.carried``) at once and
    carries the stand's difference on past the blend (``player._arms``, as a walk ↔ run carries the arms), the legs
    keeping the blend's timing: the trunk at 0.95-1.04x, the arms at 0.76-0.91x. The seeds' scripts tuned nothing."""
    cues, adverbs = gesture_script(seed)
    perf = perform(bandai, cues, seconds=8.0, seed=seed, adverbs=adverbs, start="idle")
    speed = np.concatenate([np.zeros((1, bandai.skeleton.num_joints)), _angular_speed(perf.planted.rotations)])
    own = {}
    for verb, after in (("idle", 2), ("walk", 30)):
        alone = perform(bandai, [], seconds=6.0, seed=seed, start=verb, adverbs=adverbs, stay=True).planted.rotations
        own[verb] = _angular_speed(alone)[after:]
    starts = _windows(perf, bandai, {("idle", "walk")})
    assert starts and starts[0][2] <= 5, f"the script should start walking at once: {starts}"
    failures = []
    for part in ("trunk", "arms"):
        joints = _parts(bandai)[part]
        bound = 1.5 * max(own["idle"][:, joints].max(), own["walk"][:, joints].max())
        for _, _, a, b in starts:
            fastest = speed[a:b, joints].max()  # the steps into frames a to b - 1
            if fastest > bound:
                failures.append(f"{part} at {a / FPS:.2f} s: {fastest:.2f} rad/s, 1.5x its verbs' own {bound:.2f}")
    assert not failures, "\n".join(failures)


@pytest.mark.parametrize("seed", [21, 27, 43])
def test_a_stop_soon_after_a_start_carries_the_upper_body_on(bandai, seed):
    """A stop (or a walk into a run) carries the arms alone; begun while a start's offset of the whole upper body is
    still alive (its ``ARMS_BLEND``), it carries the whole upper body on again from the pose shown. A version that
    carried the arms alone there dropped the trunk's offset in a frame: the trunk at 3-6x its verbs' own as the stop
    began (at these seeds 4.9x, 5.2x and 6.2x; 2-5.6x in 53 of 150 random scripts of ``benchmarks/edges.py``)."""
    rng = np.random.default_rng(seed)
    adverbs = {"valence": float(rng.uniform(-0.6, 0.6)), "energy": float(rng.uniform(-0.4, 0.4))}
    cues = [Cue(0.3, "walk"), Cue(float(rng.uniform(0.8, 1.3)), "idle")]
    perf = perform(bandai, cues, seconds=4.0, seed=seed, adverbs=adverbs, start="idle")
    start, stop = _windows(perf, bandai, {("idle", "walk"), ("walk", "idle")})[:2]
    assert start[:2] == ("idle", "walk") and stop[:2] == ("walk", "idle") and stop[2] - start[2] < 1.2 * FPS, (start, stop)
    trunk = _parts(bandai)["trunk"]
    own = 0.0
    for v in {int(v) for v in perf.verb if v >= 0}:
        alone = perform(bandai, [], seconds=6.0, seed=seed, start=bandai.verb_names[v], adverbs=adverbs, stay=True)
        own = max(own, _angular_speed(alone.planted.rotations)[30 if bandai.verbs[v].cyclic else 2 :, trunk].max())
    speed = _angular_speed(perf.planted.rotations)[:, trunk].max(axis=1)
    assert speed.max() <= 1.5 * own, f"the trunk at {speed.max():.2f} rad/s at {(np.argmax(speed) + 1) / FPS:.2f} s, its verbs' own {own:.2f}"


@pytest.mark.parametrize("seed, seconds", [(138, 13.0), (148, 17.0)])
def test_a_blend_begun_under_a_decaying_offset_takes_over_its_arms_part(bandai, seed, seconds):
    """A walk <-> run begun while the whole pose's offset still decays (left by a blend cut short) takes the arms'
    offset from the pose shown, which holds the whole pose's; that offset, still decaying on the arms too, came back
    in one frame as the blend ended and the verb entered played alone (an upper arm at 8.2 rad/s between frames at 2.9
    and 2.2; on the Bandai stand on its feet a hand at 19.6). The carried joints' part of it is handed to the arms'
    offset: no arm joint's speed changes from one frame to the next more than the walk's and the run's own do (without
    it 1.28x and 1.18x here; now 0.27x and 0.30x). The seeds' scripts tuned nothing."""
    cues, adverbs = gesture_script(seed)
    perf = perform(bandai, cues, seconds=seconds, seed=seed, adverbs=adverbs, start="idle")
    arms = _parts(bandai)["arms"]
    jerk = np.abs(np.diff(_angular_speed(perf.planted.rotations)[:, arms], axis=0)).max(axis=1)
    own = 0.0
    for verb in ("walk", "run"):
        alone = perform(bandai, [], seconds=6.0, seed=seed, start=verb, adverbs=adverbs, stay=True).planted.rotations
        own = max(own, np.abs(np.diff(_angular_speed(alone)[30:, arms], axis=0)).max())
    windows = _windows(perf, bandai, {("run", "walk"), ("walk", "run")})
    assert windows
    for s, t, a, b in windows:
        assert jerk[a - 2 : b + 15].max() <= own, f"{s}→{t} at {a / FPS:.2f} s: {jerk[a - 2 : b + 15].max():.2f} rad/s, own {own:.2f}"


@pytest.mark.parametrize("seed", [43, 44, 49])
def test_a_stop_turned_back_into_the_walk_at_once_keeps_the_arms_on(bandai, seed):
    """A walk cue the frame after a stop began turns the stop back, and the turned-back blend is over within that
    frame: the walk plays alone. The arms' offset the stop had taken against the stand's arms was shown on the walk's
    instead: a hand 27 cm in one frame (benchmarks/edges.py, seed 224), the arms at 3.5-11x the walk's own at seeds
    40-51. It is taken again against the walk's: at most 1.02x there. Seed 44 had an offset of an earlier run → walk
    still fading, which ending the stop's offset (not taking it again) dropped in one frame (3.4x)."""
    rng = np.random.default_rng(seed)
    adverbs = {"valence": float(rng.uniform(-0.5, 0.5)), "energy": float(rng.uniform(-0.5, 0.5))}
    cues = [Cue(0.5, "walk"), Cue(float(rng.uniform(2.0, 4.0)), "idle")]
    walk = bandai.verb_index("walk")
    plain = perform(bandai, cues, seconds=8.0, seed=seed, adverbs=adverbs, start="idle")
    start = _begins(bandai, plain, "walk", "idle")
    perf = perform(bandai, [*cues, Cue((start + 1) / FPS, "walk")], seconds=8.0, seed=seed, adverbs=adverbs, start="idle")
    assert perf.active[start] == plain.active[start] and perf.active[start + 1] < 0 and perf.verb[start + 1] == walk, (
        "the walk cue should turn the stop back, over within the frame after it began"
    )
    arms = _parts(bandai)["arms"]
    own = _angular_speed(perform(bandai, [], seconds=6.0, seed=seed, start="walk", adverbs=adverbs, stay=True).planted.rotations)
    fastest = _angular_speed(perf.planted.rotations)[start - 1 : start + 15][:, arms].max()
    assert fastest <= 1.5 * own[30:, arms].max(), f"an arm at {np.degrees(fastest):.0f} deg/s (the walk's own {np.degrees(own[30:, arms].max()):.0f})"


@pytest.mark.parametrize("seed", [
    213,
    224,  # 1.54x until session 47 (a cosine blend into a one-shot now limits the carried body's acceleration too)
    227])  # fmt: skip
def test_a_standing_body_carried_by_its_feet_speeds_up_no_harder_than_its_verbs(bandai, seed):
    """Under the decaying offset an interruption leaves, the body carried by its held feet changed its velocity at up
    to 4 m/s², a walk's pace: a stand cut short into a bow, a reach or a wave jumped the body at 1.6-7x its verbs' own
    (a stand sways at 0.1-0.2 m/s², a bow at 0.6-0.8). Its limit is now its verbs' own at its adverbs
    (``player.carry_limits``, ``Verb.carry_limit``), held whether or not a foot is: a carry that ended
    (its feet let go) had put the body back on its own velocity in one frame. Random gesture scripts (of 30 tried,
    these broke the bound by the most, at 6.9, 4.8 and 7.0x): no transition between standing verbs accelerates the
    body root more than 1.5x its verbs' own."""
    from test_transitions import STILL, _root_acceleration

    cues, adverbs = gesture_script(seed)
    perf = perform(bandai, cues, seconds=28.0, seed=seed, adverbs=adverbs, start="idle")
    acc = _root_acceleration(perf, bandai)
    standing = ("idle", "reach", "bow", "guide", "bye")
    own = {v: max(_root_acceleration(perform(bandai, [], seconds=6.0, seed=seed, start=v, adverbs=adverbs, stay=True), bandai)[2:].max(), STILL)
           for v in standing}  # fmt: skip (a stand in place has none of its own: test_transitions.STILL)
    entries = _windows(perf, bandai, {(x, y) for x in standing for y in standing})
    assert len(entries) >= 8, entries
    for s, t, a, b in entries:
        ref = max(own[s], own[t])
        assert acc[a:b].max() <= 1.5 * ref, f"{s}→{t} at {a / FPS:.2f} s: root at {acc[a:b].max() / ref:.2f}x its verbs' own"


def test_a_one_shot_waiting_at_its_end_shows_its_last_pose(bandai):
    """A one-shot's generic time is its own, 0 to 1; at its end (g = 1, or past it for a frame while its next transition
    starts) it shows its last pose and goes at its last velocity. Taken as the start of a next lap, it showed its first:
    a stand that a gesture → stand left at its end snapped to its start pose, arms and body at once (in 26 of 156
    idle → idle windows of the benchmark's random scripts an arm turned over 1.5x the stand's own)."""
    from adverbs.graph.player import _dofs
    from adverbs.graph.state import new_state

    state = new_state(bandai, 4, 0, "idle")
    idle = bandai.verb_index("idle")
    g = np.array([1.0, 1.07, 1.0 - 1e-9, 0.0])
    d = _dofs(state, np.full(4, idle), g, 0, np.arange(4))[idle][1]
    np.testing.assert_allclose(d[0], d[2], rtol=0, atol=1e-6)  # its end, as it comes to it
    np.testing.assert_allclose(d[1], d[0], rtol=0, atol=0)  # past it: still its end
    assert np.abs(d[0] - d[3]).max() > 1e-2  # not its start (the stand's end pose differs from its first)


@pytest.mark.parametrize("name", ["idle", "reach", "walk", "bow"])
def test_the_carry_limit_at_an_examples_point_is_that_examples_own(bandai, name):
    """The limit on how fast a carried body changes its velocity is its verb's own at the creature's adverbs: the root
    velocities it plays there (the examples' blended with its weights) differentiated in its clock time and turned
    with its heading, at their fastest (``Verb.carry_limit``, read by ``player.carry_limits`` and the compiled
    frame). At an example's own point (its weight 1, the others' 0) that is the example's own fastest
    (``Verb.root_accelerations``), to rounding; between them it is no more than the fastest of them (the limit
    before: the examples' fastest blended, which for a reach was twice its own at the point); a crowd's are each
    creature's alone."""
    from adverbs.verb.tables import SETTLING

    verb = bandai.verbs[bandai.verb_index(name)]
    samples, fastest = verb.root_velocity_samples, verb.root_accelerations
    assert samples.shape == (len(fastest), samples.shape[1], 3) and samples.shape[1] >= 65
    assert fastest.min() >= SETTLING  # (a stand in place has none of its own)
    weights = np.array([verb.weights(point) for point in verb.points])
    np.testing.assert_allclose(verb.carry_limit(weights), fastest, rtol=1e-9, atol=0)
    rng = np.random.default_rng(3)
    points = rng.uniform(verb.points.min(axis=0), verb.points.max(axis=0), (7, verb.points.shape[1]))
    crowd = np.array([verb.weights(p) for p in points])
    assert np.array_equal(verb.carry_limit(crowd), [verb.carry_limit(w) for w in crowd])
    assert verb.carry_limit(verb.weights(verb.points.mean(axis=0))) <= fastest.max() + 1e-12


@pytest.mark.parametrize("name, seed", [("walk", 5), ("walk", 11), ("run", 7), ("run", 13)])
def test_the_carry_limit_is_near_what_the_verb_shows_at_the_point(bandai, name, seed):
    """A verb's carry limit at a point is near the fastest root acceleration it shows played there alone, read off its
    frames, at 6 random points: at most 1.1x its fastest, and at least 0.85x its fastest outside its loops into
    itself (a loop's blend, which the limit does not see, can turn the body harder than the verb's cycle: up to 1.5x
    a walk's; 0.88-1.09x at these points).
    Each example's acceleration in its own clock blended, ``|v'| + |ω| |v|`` at 64 points of its cycle and kept at
    least the slowest example's (the limit until session 59), said up to 1.9x for the walk (seed 5: 1.13-1.93x) and
    1.6x for the run: a start cut short carried the body at 1.5x what its walk shows
    (``test_a_start_cut_short_by_a_command_speeds_up_as_the_walk_does``), a walk → run at 1.6x the run's."""
    from test_transitions import _root_acceleration

    verb = bandai.verbs[bandai.verb_index(name)]
    rng = np.random.default_rng(seed)
    over, under = [], []
    for trial in range(6):
        point = rng.uniform(verb.points.min(axis=0), verb.points.max(axis=0))
        limit = verb.carry_limit(verb.weights(point))
        adverbs = dict(zip(verb.adverb_names, point))
        alone = perform(bandai, [], seconds=6.0, seed=trial, start=name, adverbs=adverbs, stay=True)
        acc = _root_acceleration(alone, bandai)
        looping = np.convolve(alone.active >= 0, np.ones(3), "full")[: len(acc)] > 0  # the frame or the two before
        over.append(limit / acc[30:].max())
        under.append(limit / acc[30:][~looping[30:]].max())
    assert max(over) <= 1.1 and min(under) >= 0.85, (np.round(over, 3), np.round(under, 3))


def test_the_carry_limit_is_kept_until_the_adverbs_move(bandai):
    """A creature's carry limits change only with its adverbs, so each is kept once a frame has worked it out
    (``clocks._carry``, beside its sampling caches), NaN again when its adverbs move: the compiled frame blended
    every example's root accelerations at 64 generic times for every creature under a carry, every frame. What
    either path works out is the verb's own at the creature's point (``Verb.carry_limit``), to rounding."""
    from adverbs.graph.clocks import _carry, _sampling
    from adverbs.graph.planted import planter
    from adverbs.graph.queue import command
    from adverbs.graph.state import new_state
    from adverbs.runtime.frame import FramePass

    n = 6
    state = new_state(bandai, n, 0, "walk")
    fp = FramePass(state, planter(bandai, n))
    walk = bandai.verb_index("walk")
    tables, offsets = fp._caches
    kept = tables[10][:, offsets[5][walk]]  # slot 0's, where the pass reads and writes
    assert np.isnan(kept).all()
    for c in range(n):
        command(state, c, "idle")  # a stop: a cosine blend into a one-shot, its body carried under the limit
    for _ in range(45):
        fp.step(1 / 30)
    done = np.flatnonzero(~np.isnan(kept))
    assert len(done) == n  # every stop needed it
    weights = _sampling(state, walk, 0).weights
    np.testing.assert_allclose(kept, bandai.verbs[walk].carry_limit(weights), rtol=1e-12, atol=0)
    before = kept.copy()
    state.points[2, bandai.adverb_names.index("valence")] = 0.8  # one creature's adverbs move
    weights = _sampling(state, walk, 0).weights  # (the caches brought up to date, as a frame's first step does)
    assert np.isnan(kept).all()  # every one's is worked out again where a frame needs it
    limits = _carry(state, walk, 0, np.arange(n))  # the reference path's: worked out and kept
    np.testing.assert_allclose(limits, bandai.verbs[walk].carry_limit(weights), rtol=1e-12, atol=0)
    assert np.array_equal(kept, limits) and limits[2] != before[2]
    np.testing.assert_allclose(limits[[0, 1, 3, 4, 5]], before[[0, 1, 3, 4, 5]], rtol=1e-12, atol=0)


def test_a_standing_foot_is_re_placed_only_far_off_or_with_the_body_off_both():
    """``planted._standing_far``, the rule for creatures that stand: a held flat foot is re-placed when it is
    ``STANDING`` from where the verbs have it, or when every foot is held flat and their mean offset (the body gone
    from over them) is over ``SHIFTED``: then only the further one; a foot not held flat never."""
    from adverbs.graph.planted import SHIFTED, STANDING, _standing_far

    def far(left, right, flat=(True, True)):
        away = np.array([[[left[0], 0.0, left[1]], [right[0], 0.0, right[1]]]])
        gap = np.hypot(away[..., 0], away[..., 2])
        return _standing_far(np.array([flat]), away, gap)[0].tolist()

    below, above = STANDING - 0.005, STANDING + 0.005
    assert far((below, 0.0), (0.0, 0.0)) == [False, False]  # a stance 14.5 cm apart from the verbs': held
    assert far((0.0, above), (0.0, 0.0)) == [True, False]
    assert far((above, 0.0), (0.0, 0.0), flat=(False, True)) == [False, False]  # rolling or free: not this rule's
    assert far((-0.01, 0.0), (above, 0.0)) == [False, True]
    shift = 2 * SHIFTED + 0.01  # both feet off the same way, the body off them: the further steps, one at a time
    assert far((shift / 2 + 0.01, 0.0), (shift / 2 - 0.01, 0.0)) == [True, False]
    assert far((0.0, shift / 2 - 0.01), (0.0, shift / 2 + 0.01)) == [False, True]
    assert far((shift / 2 + 0.01, 0.0), (shift / 2 - 0.01, 0.0), flat=(True, False)) == [False, False]
    assert far((SHIFTED + 0.01, 0.0), (-SHIFTED - 0.01, 0.0)) == [False, False]  # a wider stance: the body over it


@pytest.mark.parametrize("seed", [306, 311, 323, 418, 216, 302, 318])
def test_a_stop_leaves_the_stand_and_the_gestures_after_it_on_their_own_stance(bandai, seed):
    """A stop held its feet to 15 cm like any stand (``planted.STANDING``): the walk's last stance foot, 9-14 cm from
    where the stand has it at sad valences, stayed there through the stand and the gestures after it until their
    own sway took it past 15 cm, and it stepped in the middle of a gesture, the knee at 4-9x the stand's and the
    gesture's own legs (at these seeds, in an idle → reach: 8.9x, 6.5x and 4.2x). A stop now re-places
    a foot 9 cm off (``planted.STOPPING``): it steps as the stop ends, at the walk's pace, within the stop's half
    second. Seed 418's stop left a foot 14 cm off that was never flat as the planter took it (rolled 0.1-0.2 because
    the stand's foot is a little higher there): held with its heel lifted through a bow, a stand and a reach, it
    stepped as a guide began (2.8x); a standing foot is flat where the verbs hold it flat now. A stop's trailing foot
    that crossed 9 cm while the walk's fading weight still rolled it a little (or while the other foot stepped) was
    not re-placed, and once the stop ended 15 cm held again: parked 11-12 cm off, it stepped mid-reach as the reach's
    stance took it past 15 cm (seeds 216, 302, 318 since session 59's carry limit: 5.6x, 5.7x, 7.7x). It now steps
    once it can, in the stop or after it while standing (``GraphFeet.pending``). Every standing window
    of these random scripts (a stand into a gesture, a gesture into the stand) turns the legs no faster than 1.5x
    their verbs' own (each window's, and the stop's where it settles in it)."""
    from test_transitions import _own

    cues, adverbs = gesture_script(seed)
    perf = perform(bandai, cues, seconds=28.0, seed=seed, adverbs=adverbs, start="idle")
    legs = np.r_[0.0, _angular_speed(perf.planted.rotations)[:, _parts(bandai)["legs"]].max(axis=1)]
    owns = {v: _own(bandai, v, _toes(bandai), seed, adverbs)["legs"] for v in bandai.verb_names}
    gestures = ("reach", "bow", "guide", "bye")
    kinds = {("idle", g) for g in gestures} | {(g, "idle") for g in gestures}
    every = _windows(perf, bandai, {(x, y) for x in bandai.verb_names for y in bandai.verb_names})
    worst, seen = [], 0
    for s, t, a, b, also, _ in _settled(perf, bandai, every):
        if (s, t) in kinds:
            seen += 1
            own = max(owns[v] for v in also | {s, t})
            worst.append((round(float(legs[a:b].max() / own), 2), f"{s}→{t} at {a / FPS:.2f} s"))
    assert seen >= 8, seen
    assert max(worst)[0] <= 1.5, sorted(worst)[-3:]


@pytest.mark.parametrize("gesture, valence", [("guide", 0.0), ("reach", 0.0), ("reach", -0.8), ("guide", 0.8)])
def test_a_stand_after_a_gesture_keeps_its_feet_where_the_gesture_left_them(bandai, gesture, valence):
    """The stand's takes put the feet up to 12 cm from where a gesture's end has them (the guide's left toe 11 cm
    behind). Re-placed at 6 cm, the stand after a gesture stepped at once: after the guide at valence 0 a knee at
    220 deg/s (6.0x the stand's own legs), after the reach 8.1x, and at valence -0.8 86x (the sad stand's legs are all
    but still). A creature that stands now holds its feet unless one is 15 cm off (``planted.STANDING``) or the
    body is 8 cm off both: the legs of the stand after a gesture (played alone, staying) turn no faster than 1.5x
    the stand's own. (After the happy guide the stand's loop crept 1.2 cm/s over its held feet until one was 15 cm
    off and stepped, until session 48 put the stand in place: ``specs/bandai_idle.toml``.)"""
    from test_transitions import _angular_speed

    legs = _parts(bandai)["legs"]

    def fastest(perf):
        return np.concatenate([[0.0], _angular_speed(perf.planted.rotations)[:, legs].max(axis=1)])

    adverbs = {"valence": valence}
    own = fastest(perform(bandai, [], seconds=6.0, seed=1, start="idle", adverbs=adverbs, stay=True))[2:].max()
    perf = perform(bandai, [], seconds=8.0, seed=1, start=gesture, adverbs=adverbs, stay=True)
    standing = np.flatnonzero(perf.verb == bandai.verb_index("idle"))
    assert len(standing) > 3 * FPS
    shown = fastest(perf)[standing[0] :].max()
    assert shown <= 1.5 * own, f"the stand after the {gesture}: legs at {shown / own:.2f}x its own"


_STOPS: dict = {}


def _random_stops(graph, seeds):
    """``(seed, adverbs, performance, stops)`` of each random gesture script of ``seeds`` (28 s from a stand) with a
    stop in it: its walk → idle windows. Played once for the tests that measure them."""
    key = (graph.name, tuple(seeds))
    if key not in _STOPS:
        _STOPS[key] = []
        for seed in seeds:
            cues, adverbs = gesture_script(seed)
            perf = perform(graph, cues, seconds=28.0, seed=seed, adverbs=adverbs, start="idle")
            stops = _windows(perf, graph, {("walk", "idle")})
            if stops:
                _STOPS[key].append((seed, adverbs, perf, stops))
    return _STOPS[key]


def test_stops_in_random_scripts_brake_at_the_walks_pace(bandai):
    """A stop blended the walk into the first 0.6 of the stand: so short a blend, begun at the walk's fastest (its
    speed swings 0.6-1.4 m/s twice a cycle), braked the body at 7-8 m/s², against the walk's own 4-5, in half the
    stops of random gesture scripts (benchmarks/edges.py, seeds 200-229). The stop now blends into the whole stand.
    Random scripts not used to choose it (seeds 400-411): the body's acceleration in a stop and the half second
    after it over the walk's and the stand's own (played alone at the same seed and adverbs) is at most 1.5x in all
    but one stop in ten, and never 1.6x (before: 5 of 17 over 1.5x, up to 1.77x)."""
    from test_transitions import _root_acceleration

    ratios = []
    for seed, adverbs, perf, stops in _random_stops(bandai, range(400, 412)):
        acc = _root_acceleration(perf, bandai)
        own = max(
            _root_acceleration(perform(bandai, [], seconds=6.0, seed=seed, start=v, adverbs=adverbs, stay=True), bandai)[f:].max()
            for v, f in (("walk", 30), ("idle", 2))
        )  # fmt: skip
        ratios += [acc[a:b].max() / own for _, _, a, b in stops]
    ratios = np.array(ratios)
    assert len(ratios) >= 15, len(ratios)
    assert (ratios > 1.5).sum() <= len(ratios) // 10 and ratios.max() < 1.6, np.round(np.sort(ratios)[-5:], 2)


def test_a_stops_landing_foot_comes_down_at_the_walks_pace(bandai):
    """A stop hands the walk's swinging foot to the stand's hold as soon as the walk begins to land it
    (``player.LANDS``), while the planter still kept it at the swing's least lift, 3 cm over its contact height.
    Held at once at the verbs' own height, the toe fell those 30 mm in one frame and the knee straightened at 495
    deg/s (the fixed script at seed 17). The foot is now held from the least lift the walk kept under it and settles
    onto the floor (``player.hold_phases``): 7.3 → 6.4 → 5.6 → 4.8 → 4.4 cm there, the knee at 151 deg/s at most.
    Random scripts not used to choose anything (seeds 400-411): in every stop and the half second after it, the legs
    turn no faster than 1.1x the walk's own at the same seed and adverbs (before: 10 of 18 stops over 1.0x, up to
    1.41x)."""
    from test_transitions import _angular_speed

    legs = _parts(bandai)["legs"]
    ratios = []
    for seed, adverbs, perf, stops in _random_stops(bandai, range(400, 412)):
        alone = perform(bandai, [], seconds=6.0, seed=seed, start="walk", adverbs=adverbs, stay=True)
        own = _angular_speed(alone.planted.rotations)[30:, legs].max()
        fastest = np.r_[0.0, _angular_speed(perf.planted.rotations)[:, legs].max(axis=1)]
        ratios += [(seed, round(a / FPS, 2), round(float(fastest[a:b].max() / own), 2)) for _, _, a, b in stops]
    assert len(ratios) >= 15, len(ratios)
    assert max(r for _, _, r in ratios) <= 1.1, sorted(ratios, key=lambda x: -x[2])[:5]


@pytest.mark.parametrize("seed, adverbs", [
    (3, {"valence": 0.4, "energy": 0.2}), (9, {"valence": -0.3, "energy": -0.4}), (14, {"valence": 0.0, "energy": 0.6}),
])  # fmt: skip
def test_a_start_cut_short_lifts_its_first_foot_at_the_walks_pace(bandai, seed, adverbs):
    """A start cut short by a command plays the walk at once under the decaying offset of the pose shown, still
    mostly the stand's. The planter kept the first foot over the walk's examples' whole lift from that frame on, and
    the foot rose 4.6 cm in a frame (a random script, seed 217: the knee at 750 deg/s, the walk's own 407). The lift
    kept under it now grows as the offset decays (``player._eased``). A bow asked for 0.1-0.23 s into a start:
    the legs turn no faster than 1.5x the walk's own (before: up to 1.98x, in 4 of these 9)."""
    from test_transitions import _angular_speed

    legs = _parts(bandai)["legs"]
    alone = perform(bandai, [], seconds=6.0, seed=seed, start="walk", adverbs=adverbs, stay=True)
    own = _angular_speed(alone.planted.rotations)[30:, legs].max()
    starts = [k for k, t in enumerate(bandai.transitions) if (t.source, t.target) == (bandai.verb_index("idle"), bandai.verb_index("walk"))]
    cut = 0
    for delay in (0.1, 0.17, 0.23):
        cues = [Cue(0.3, "walk"), Cue(0.3 + delay, "bow")]
        perf = perform(bandai, cues, seconds=3.0, seed=seed, adverbs=adverbs, start="idle", stay=True)
        cut += perf.active[int((0.3 + delay) * FPS)] in starts  # the bow asked for during the start
        shown = _angular_speed(perf.planted.rotations)[int(0.3 * FPS) : int(1.5 * FPS), legs].max()
        assert shown <= 1.5 * own, f"a bow {delay:.2f} s into the start: legs at {shown / own:.2f}x the walk's own"
    assert cut >= 2, cut


@pytest.mark.parametrize("seed", [0, 2, 7, 8, 12])
def test_a_walk_to_run_cut_short_by_a_command_keeps_the_swinging_foot_up(bandai, seed):
    """A walk → run cut short two frames in by a command plays the run at once under the decaying offset of the pose
    shown (the command's own verb comes later). The offset took the run's swinging foot 30-45 mm under the floor, and
    the planter kept it over the examples' lift only as far as the offset had decayed: the foot came down early and
    skimmed the floor at 3-7 m/s. Under the offset a free foot is now kept over a floor rising from where it was
    (``planter.RISE``): no toe travels low more than 2 cm further than the walk's and the run's own. Random scripts
    of that scenario (seed: adverbs, when the run is asked, the command); these three were 115-172 mm over, now
    2-31 mm under; of 14 seeds, 10 were over 2 cm (24-187 mm), then 2 (seeds 8 and 12: 40 and 28 mm). Those two
    came down at the offset's speed as well as the run's: the offset had the foot under the floor two frames before
    the run's hold opened, and it ran 8-11 cm along the floor in a frame, kept only over the run's own landing lift.
    Such a foot now lands where the verbs have it under the floor (``FootPlanter.targets``, landing early): the 14
    seeds' toes travel 16-91 mm less than the walk's and run's own."""
    rng = np.random.default_rng(seed)
    adverbs = {"valence": float(rng.uniform(-0.5, 0.5)), "energy": float(rng.uniform(-0.4, 0.4))}
    at, then = float(rng.uniform(2.5, 4.0)), str(rng.choice(["idle", "bow", "reach", "guide"]))
    cues = [Cue(0.5, "walk"), Cue(at, "run")]
    plain = perform(bandai, cues, seconds=8.0, seed=seed, adverbs=adverbs, start="idle")
    start = _begins(bandai, plain, "walk", "run")
    perf = perform(bandai, [*cues, Cue((start + 2) / FPS, then)], seconds=8.0, seed=seed, adverbs=adverbs, start="idle")
    assert perf.active[start] == plain.active[start] and perf.active[start + 2] != plain.active[start + 2], (
        "the command should cut the walk -> run short two frames in"
    )
    toes = _toes(bandai)
    own = 0.0
    for verb in ("walk", "run"):
        alone = perform(bandai, [], seconds=6.0, seed=seed, start=verb, adverbs=adverbs, stay=True)
        p = alone.planted.global_positions()[:, toes]
        own = max(own, low_travel(p, _contact(p), np.arange(30, len(p))))
    pos = perf.planted.global_positions()[:, toes]
    travel = low_travel(pos, _contact(pos), np.arange(start, start + 25))
    assert travel <= own + 0.02, f"a low toe travels {travel * 1000:.0f} mm (the walk's and run's own {own * 1000:.0f})"


def test_a_foot_re_placed_as_a_start_begins_steps_on_into_the_walk(bandai):
    """A foot the verbs hold but the planter re-places (a step in the stand) does not land early: only a foot the
    verbs have let go does (``FootPlanter.targets``). A random script's start began as the stand stepped its right
    foot; the walk's own foot there, under the decaying offset, was under the floor and coming down, and the stepping
    foot was put down for two frames and lifted again, 53 mm along the floor (the walk's own 28): 33 mm now, as
    before feet landed early."""
    cues, adverbs = gesture_script(410)
    perf = perform(bandai, cues, seconds=11.0, seed=410, adverbs=adverbs, start="idle")
    starts = _windows(perf, bandai, {("idle", "walk")})
    assert [round(a / FPS, 1) for _, _, a, _ in starts][-1] == 10.0, starts  # the start as the stand steps
    toes = _toes(bandai)
    alone = perform(bandai, [], seconds=6.0, seed=410, start="walk", adverbs=adverbs, stay=True).planted
    p = alone.global_positions()[:, toes]
    own = low_travel(p, _contact(p), np.arange(30, len(p)))
    pos = perf.planted.global_positions()[:, toes]
    _, _, a, b = starts[-1]
    travel = low_travel(pos, _contact(pos), np.arange(a - 5, b))
    assert travel <= own + 0.01, f"a low toe travels {travel * 1000:.0f} mm (the walk's own {own * 1000:.0f})"


def test_a_foot_held_through_a_start_rolls_with_the_blend(bandai):
    """A foot held in a blend rolled as far as the further of the two verbs had rolled it, whatever their weights: a
    start whose walk begins with the trailing foot rolled 0.88 rolled it so in one frame; when the walk lifted it
    while the stand still had the weight it went back to the stand's flat, then to the walk's 1. A Bandai foot held
    35° from the stand's (after a guide) turned 30° in a frame three times (918-951 deg/s, 2.8x the walk's own feet).
    The verbs' rolls are now blended as the pose is. Starts after each gesture at 12 seeds: the planted feet turn
    within 1.25x the walk's own feet (up to 1.58x before; 1.13x now)."""
    names = bandai.skeleton.names
    feet = [names.index("Foot_L"), names.index("Foot_R")]
    worst = []
    for seed in range(1, 13):
        rng = np.random.default_rng(seed)
        adverbs = {"valence": rng.uniform(-0.8, 0.8), "energy": rng.uniform(-0.8, 0.8), "turn": rng.uniform(-20, 20)}
        gesture = ["guide", "bye", "bow", "reach"][seed % 4]
        cues = [Cue(0.3, gesture), Cue(float(rng.uniform(4.0, 6.0)), "walk")]
        perf = perform(bandai, cues, seconds=9.0, seed=seed, adverbs=adverbs, stay=True)
        speed = _angular_speed(perf.planted.rotations)[:, feet]
        alone = perform(bandai, [], seconds=6.0, seed=seed, start="walk", adverbs=adverbs, stay=True)
        own = _angular_speed(alone.planted.rotations)[30:, feet].max()
        starts = _windows(perf, bandai, {("idle", "walk")})
        assert len(starts) == 1, starts
        _, _, a, b = starts[0]
        worst.append((float(speed[a - 1 : b - 1].max() / own), seed, gesture))
    assert max(worst)[0] <= 1.25, max(worst)


def _dense_levels(verb, p, n=256):
    """Each foot's lowest over its hold at point ``p``: the verb's pose at ``n`` generic times of the hold, full FK."""
    from adverbs.kinematics.fk import forward_kinematics

    times = verb.hold_times(verb.weights(p[None]))[0]
    tips = [verb.skeleton.index(c.effector) for c in verb.constraints]
    out = []
    for i, h in enumerate(verb.holds):
        t = np.linspace(h.open, times[i, 2], n) % 1.0
        rot, trans = verb.encoding.decode_pose(verb.dofs(np.repeat(p[None], n, 0), t), np.zeros(3))
        pos, _ = forward_kinematics(verb.skeleton.parents, rot, trans)
        out.append((pos[:, tips[i], 1] - verb.floor - h.height).min())
    return np.array(out)


@pytest.mark.parametrize("graph_name", ["bandai", "cmu"])
def test_a_verbs_contact_level_is_the_lowest_its_foot_comes_in_its_hold(bandai, cmu, graph_name):
    """``Verb.contact_levels``: how far a cycle's stance sits over or under the floor at adverb points, each foot's
    lowest over its hold in the verb's own pose there (what the planter takes a verb's level to be before it has stood
    a foot in it). Within 1.5 mm of the pose sampled 256 times over the hold, at every example and at random points
    among them; a crowd's are each creature's alone (to rounding); a stand has none; a NaN adverb is refused."""
    from adverbs.errors import AdverbsError

    graph = {"bandai": bandai, "cmu": cmu}[graph_name]
    rng = np.random.default_rng(3)
    for verb in graph.verbs:
        if not verb.cyclic:
            assert np.isnan(verb.contact_levels(verb.points[:2])).all()
            continue
        lo, hi = verb.points.min(axis=0), verb.points.max(axis=0)
        points = np.concatenate([verb.points, lo + (hi - lo) * rng.uniform(0, 1, (6, len(lo)))])
        levels = verb.contact_levels(points)
        dense = np.array([_dense_levels(verb, p) for p in points])
        np.testing.assert_allclose(levels, dense, rtol=0, atol=0.0015)
        assert np.ptp(levels) > 0.005  # the adverbs move it
        for i in (0, len(points) - 1):
            np.testing.assert_allclose(verb.contact_levels(points[i : i + 1])[0], levels[i], rtol=0, atol=1e-12)
        # A point's levels are kept once worked out; what a caller does with its copy changes nothing kept.
        mine = verb.contact_levels(points[:1])
        mine[:] = 99.0
        np.testing.assert_allclose(verb.contact_levels(points[:1])[0], levels[0], rtol=0, atol=1e-12)
        # A crowd whose creatures share points (worked out once a point) has each point's own levels.
        shared = verb.contact_levels(np.concatenate([points[::-1], points, points[:1]]))
        np.testing.assert_allclose(shared, np.concatenate([levels[::-1], levels, levels[:1]]), rtol=0, atol=1e-12)
        with pytest.raises(AdverbsError, match="finite"):
            verb.contact_levels(np.full((1, len(lo)), np.nan))
        with pytest.raises(AdverbsError, match="finite"):
            verb.contact_levels(np.concatenate([points[:1], np.full((2, len(lo)), np.nan)]))


def test_know_levels_fills_what_the_planter_has_not_taken(cmu):
    """Before a frame, each creature's verbs (playing, entering, next) get the levels the planter has not taken yet,
    worked out at the creature's own adverbs; levels it took stay; a verb already looked at is not worked again; a
    look after the first takes in only the creatures whose queues moved, and finds what a first look finds."""
    from adverbs.graph.planted import know_levels, planter
    from adverbs.graph.queue import command
    from adverbs.graph.state import new_state

    points = np.stack([cmu.point({"walk_speed": 1.0, "run_speed": 2.5}), cmu.point({"walk_speed": 1.6, "run_speed": 3.8})])
    state = new_state(cmu, 2, 0, "walk", points=points, stay=True)
    feet = planter(cmu, 2)
    walk, run = cmu.verb_index("walk"), cmu.verb_index("run")
    feet.levels[0, 0, walk] = 0.123  # taken by the planter
    know_levels(feet, state)
    cols = cmu.hold_layout[walk][1]
    own = cmu.verbs[walk].contact_levels(cmu.verb_points(walk, points))
    np.testing.assert_array_equal(feet.levels[1, cols, walk], own[1])
    assert feet.levels[0, cols[0], walk] == 0.123 and feet.levels[0, cols[1], walk] == own[0, 1]
    assert np.isnan(feet.levels[:, :, run]).all() and not feet.known[:, run].any()
    command(state, 1, "run", stay=True)  # next: the run, for creature 1 alone
    know_levels(feet, state)  # looks at creature 1 alone (its queue was noted since the last look: head_stamp)
    assert np.isnan(feet.levels[0, :, run]).all() and np.isfinite(feet.levels[1, :, run]).all()
    whole = planter(cmu, 2)
    know_levels(whole, state)  # a planter's first look takes in every creature: the same levels
    np.testing.assert_array_equal(whole.levels[:, :, run], feet.levels[:, :, run])
    np.testing.assert_array_equal(whole.known, feet.known)
    feet.levels[1, :, run] = 0.5
    know_levels(feet, state)
    assert (feet.levels[1, :, run] == 0.5).all()


@pytest.mark.parametrize("name, adverbs", [
    ("bandai", {"valence": -0.18, "energy": -0.91, "turn": -64.92}),
    ("cmu", {"walk_speed": 0.82, "turn": 119.88}),
])  # fmt: skip
def test_a_walk_played_alone_keeps_the_feet_it_has_down_on_the_floor(bandai, cmu, monkeypatch, name, adverbs):
    """A walk's own stance foot slides from where it landed (a blend of takes; a turn), and held where it landed it is
    2-7 cm from the walk's by toe-off at most adverb points. Re-placed 6 cm off (``planted.REPLANT``), a stance foot
    the walk had flat on the floor was lifted 3 cm and glided on mid-stance, every few steps: at these points (drawn
    at random; nothing tuned on them) 21 and 28 frames in 8 s showed a toe over 15 mm up while the walk had it within
    5 mm of its contact height. A foot is re-placed 12 cm off now, as in a blend: none."""
    graph = {"bandai": bandai, "cmu": cmu}[name]
    toes = [graph.skeleton.names.index(n) for n in {"bandai": ("Toes_L", "Toes_R"), "cmu": ("ltoes", "rtoes")}[name]]

    def hovering() -> int:
        perf = perform(graph, [], seconds=8.0, seed=4, start="walk", adverbs=adverbs, stay=True)
        shown, walk = perf.planted.global_positions()[30:, toes, 1], perf.free.global_positions()[30:, toes, 1]
        contact = np.percentile(shown, 1, axis=0)
        return int(((walk - contact < 0.005) & (shown - contact > 0.015)).sum())

    assert hovering() == 0
    from adverbs.graph import planted

    monkeypatch.setattr(planted, "REPLANT", 0.06)
    assert hovering() > 10  # re-placed 6 cm off, as it was: the measure sees it
