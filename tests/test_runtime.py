"""The run-time loop: event semantics, the wall clock under load, deterministic offline runs, refusals that keep
the run going, scripts checked before they run, adverbs eased, one creature or many the same."""

from __future__ import annotations

import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from adverbs import AdverbsError, CommandRefused, load_graph, read_bvh
from adverbs.errors import AdverbsWarning
from adverbs.runtime import NORMAL, OPTIONAL, SYNC, EventQueue, Simulation, VirtualClock, WallClock, run_events
from adverbs.runtime.script import ScriptError, load_script

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def cmu():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        return load_graph(ROOT / "graphs" / "cmu.toml")


# ----- events -------------------------------------------------------------------------------------------


def test_events_run_in_timestamp_order_then_insertion_order():
    q, ran = EventQueue(), []
    for t, name in [(2.0, "c"), (1.0, "a"), (2.0, "d"), (1.0, "b"), (0.5, "first"), (2.0, "e")]:
        q.push(t, lambda _t, n=name: ran.append(n), NORMAL, name)
    run_events(q, VirtualClock())
    assert ran == ["first", "a", "b", "c", "d", "e"]


def test_events_pushed_by_callbacks_take_their_place_in_order():
    q, ran = EventQueue(), []
    q.push(1.0, lambda t: (ran.append("one"), q.push(1.5, lambda t: ran.append("pushed"))))
    q.push(2.0, lambda t: ran.append("two"))
    q.push(1.0, lambda t: ran.append("tie after one"))
    run_events(q, VirtualClock())
    assert ran == ["one", "tie after one", "pushed", "two"]


def test_sync_waits_for_the_clock_normal_does_not():
    clock = WallClock()
    q, at = EventQueue(), {}
    q.push(0.15, lambda t: at.__setitem__("sync", clock.now()), SYNC)
    q.push(0.0, lambda t: at.__setitem__("normal", clock.now()), NORMAL)
    q.push(5.0, lambda t: at.__setitem__("late normal", clock.now()), NORMAL)  # far ahead of the clock: runs anyway
    clock.start()
    run_events(q, clock)
    assert at["sync"] >= 0.15
    assert at["normal"] < 0.1
    assert at["late normal"] < at["sync"] + 0.1  # did not wait for 5 s
    # a sync event whose time has gone by runs at once
    q.push(0.01, lambda t: at.__setitem__("gone by", clock.now()), SYNC)
    before = clock.now()
    run_events(q, clock)
    assert at["gone by"] - before < 0.05


def test_optional_events_are_skipped_when_late_and_run_when_early():
    clock = VirtualClock(start=1.0)
    q, ran = EventQueue(), []
    q.push(0.5, lambda t: ran.append("late optional"), OPTIONAL, "late optional")
    q.push(0.5, lambda t: ran.append("late normal"), NORMAL)
    q.push(1.0, lambda t: ran.append("on time optional"), OPTIONAL)
    q.push(1.5, lambda t: ran.append("early optional"), OPTIONAL)
    q.push(2.0, lambda t: ran.append("sync"), SYNC)
    q.push(1.9, lambda t: ran.append("optional before the sync"), OPTIONAL)
    done = run_events(q, clock)
    assert ran == ["late normal", "on time optional", "early optional", "optional before the sync", "sync"]
    assert done.skipped == [(0.5, "late optional")]
    assert clock.now() == 2.0


def test_events_refuse_bad_times_and_kinds():
    q = EventQueue()
    with pytest.raises(AdverbsError, match="finite"):
        q.push(float("nan"), print)
    with pytest.raises(AdverbsError, match="kind"):
        q.push(1.0, print, "urgent")


def test_run_events_stops_at_until_and_keeps_the_rest():
    q, ran = EventQueue(), []
    for t in (1.0, 2.0, 3.0):
        q.push(t, lambda t: ran.append(t))
    run_events(q, VirtualClock(), until=2.0)
    assert ran == [1.0, 2.0] and len(q) == 1


# ----- the wall clock under load ------------------------------------------------------------------------


def test_real_time_loop_lowers_its_frame_rate_under_load_and_shows_frames_on_time(cmu):
    warm = Simulation(cmu)
    warm.add_creature().perform("run")
    warm.run(1.0)  # compiled kernels (a transition's too) ready before the clock matters, even with no numba cache
    sim = Simulation(cmu, fps=30.0, realtime=True)
    sim.add_creature().perform("run")
    sim.run(1.0)
    free = np.diff(sim.frame_times)
    assert np.median(free) == pytest.approx(1 / 30, rel=0.05)  # unloaded: the asked rate
    load = 0.08  # seconds each render now takes: more than a 30 fps frame
    sim.run(2.0, on_render=lambda s: time.sleep(load))
    times = np.asarray(sim.frame_times[len(free) + 1 :])
    lags = np.asarray(sim.lags[len(free) + 1 :])
    steps = np.diff(times)
    assert np.median(steps) >= load  # the frame rate came down to what the load allows ...
    assert np.median(steps) < 2.5 * load  # ... and not far below it
    # ... and every frame was shown within one frame of its time (2 cores shared with other tests: a margin)
    assert np.all(lags[1:] <= steps + 0.02), (lags.max(), steps.min())


# ----- offline runs are the same every time ------------------------------------------------------------

SCRIPT = """
seconds = 6
seed = 3
[[creatures]]
name = "a"
at = [0.0, 0.0]
[[creatures]]
name = "b"
at = [2.0, 0.0]
heading = 90
adverbs = { walk_speed = 1.6 }
[[cues]]
at = 0.5
creature = "a"
perform = "run"
adverbs = { run_speed = 3.2, turn = 30 }
[[cues]]
at = 3.0
creature = "b"
adverbs = { turn = -40 }
over = 1.0
[[cues]]
at = 4.0
creature = "a"
perform = "walk"
"""


def test_same_script_and_seed_give_identical_bvh(tmp_path, cmu):
    from adverbs.apps.scene import run_script

    script = tmp_path / "script.toml"
    script.write_text(SCRIPT)
    graph = ROOT / "graphs" / "cmu.toml"
    outs = []
    for k in range(2):
        sim, paths = run_script([graph], script, tmp_path / f"run{k}", quiet=True)
        outs.append({n: p.read_bytes() for n, p in paths.items() if n != "events"})
    assert outs[0] == outs[1]
    clip = read_bvh(tmp_path / "run0" / "a.bvh")
    assert clip.num_frames == 180 and clip.fps == 30.0
    ran = [e for e in sim.log if e["command"] == "perform"]
    assert [(e["time"], e["verb"], e["status"]) for e in ran] == [(0.5, "run", "ran"), (4.0, "walk", "ran")]
    # What a creature reports of its last frame is that frame's world joint positions.
    a = sim.creature("a")
    assert a.positions().shape == (clip.skeleton.num_joints, 3)
    np.testing.assert_allclose(a.positions(), a.clip().global_positions()[-1], rtol=0, atol=1e-9)


def test_wandering_creatures_follow_their_seed(cmu):
    def path(seed):
        sim = Simulation(cmu, seed=seed, record=False)
        c = sim.add_creature(wander=True)
        sim.run(12.0)
        return [(e["time"], e["to"]) for e in sim.log if e["command"] == "transition"], c.root

    assert path(1) == path(1)
    assert path(1) != path(2)


# ----- one path for one creature or many ----------------------------------------------------------------


def test_many_creatures_move_as_each_would_alone(cmu):
    setups = [
        {"at": (0.0, 0.0), "heading": 0.0, "adverbs": {"walk_speed": 1.1}},
        {"at": (3.0, 1.0), "heading": 45.0, "verb": "run", "adverbs": {"run_speed": 3.4, "turn": 30.0}},
        {"at": (-2.0, 4.0), "heading": -90.0, "adverbs": {"walk_speed": 1.6, "turn": -50.0}},
    ]
    together = Simulation(cmu)
    crowd = [together.add_creature(**s) for s in setups]
    crowd[0].perform("run", at=1.0)
    crowd[2].set_adverbs(turn=20.0, over=0.8, at=2.0)
    together.run(4.0)
    for k, s in enumerate(setups):
        alone = Simulation(cmu)
        c = alone.add_creature(**s)
        if k == 0:
            c.perform("run", at=1.0)
        if k == 2:
            c.set_adverbs(turn=20.0, over=0.8, at=2.0)
        alone.run(4.0)
        a, b = crowd[k].clip(), c.clip()
        np.testing.assert_allclose(a.translations, b.translations, rtol=0, atol=1e-9)
        np.testing.assert_allclose(a.rotations, b.rotations, rtol=0, atol=1e-9)


# ----- refusals -------------------------------------------------------------------------------------------


def test_bad_commands_are_refused_and_the_run_goes_on(cmu):
    sim = Simulation(cmu)
    c = sim.add_creature(adverbs={"walk_speed": 1.3})
    sim.run(1.0)
    before = c.root
    for bad in (lambda: c.perform("fly"), lambda: c.set_adverbs(mood=1.0), lambda: c.set_adverbs(walk_speed=float("nan")),
                lambda: c.set_adverbs(walk_speed=40.0), lambda: c.set_adverbs(turn="left"), lambda: c.set_adverbs(turn=10, over=-1)):  # fmt: skip
        with pytest.raises(CommandRefused):
            bad()
    assert c.root == before and c.adverbs["walk_speed"] == 1.3  # nothing changed
    # the same, from the queue: logged as refused, warned, and the next good command still runs
    c.perform("fly", at=1.5)
    c.set_adverbs(walk_speed=float("inf"), at=1.6)
    c.set_adverbs(walk_speed=-30.0, at=1.7)
    c.perform("run", at=2.0)
    with pytest.warns(AdverbsWarning) as caught:
        sim.run(3.0)
    refused = [e for e in sim.log if e["status"] == "refused"]
    assert [e["time"] for e in refused][-3:] == [1.5, 1.6, 1.7]
    assert "no verb 'fly'" in refused[-3]["reason"] and "finite" in refused[-2]["reason"] and "out of range" in refused[-1]["reason"]
    assert len([w for w in caught if issubclass(w.category, AdverbsWarning)]) == 3  # (not a warning from elsewhere)
    assert c.verb == "run" and sim.frames == 120
    assert np.linalg.norm(np.subtract(c.root[:2], before[:2])) > 3.0  # it kept moving all along


def test_api_mistakes_are_clear(cmu):
    sim = Simulation(cmu)
    with pytest.raises(AdverbsError, match="no creatures"):
        sim.run(1.0)
    sim.add_creature(name="a")
    with pytest.raises(AdverbsError, match="already called"):
        sim.add_creature(name="a")
    with pytest.raises(CommandRefused, match="no verb 'fly'"):
        sim.add_creature(verb="fly")
    with pytest.raises(AdverbsError, match="no graph"):
        sim.add_creature(graph="bandai")
    with pytest.raises(AdverbsError, match="seconds"):
        sim.run(float("nan"))
    sim.run(0.5)
    with pytest.raises(AdverbsError, match="before the simulation's first frame"):
        sim.add_creature()
    with pytest.raises(AdverbsError, match="time"):
        sim.creature("a").perform("run", at=0.1)  # in the past


# ----- adverbs eased -----------------------------------------------------------------------------------------


def test_adverb_changes_are_eased_and_do_not_pop(cmu):
    sim = Simulation(cmu, fps=60.0)
    c = sim.add_creature(adverbs={"walk_speed": 0.9})
    sim.run(3.0)
    c.set_adverbs(walk_speed=1.8, over=1.0)
    seen = []
    sim.run(4.0, on_frame=lambda s: seen.append((s.time, c.adverbs["walk_speed"])))
    t, v = np.array(seen).T
    t -= 3.0
    # a smoothstep from 0.9 to 1.8 over one second, then held
    u = np.clip(t, 0, 1)
    np.testing.assert_allclose(v, 0.9 + 0.9 * u * u * (3 - 2 * u), rtol=0, atol=1e-12)
    pos = c.clip().global_positions()
    speed = np.linalg.norm(np.diff(pos, axis=0), axis=-1).max(axis=1) * 60.0
    before, during, after = speed[60:179].max(), speed[180:300].max(), speed[330:].max()
    assert during <= 1.5 * max(before, after), (before, during, after)


def test_an_adverb_change_eases_as_long_as_it_needs_unless_told(cmu):
    """By default a change eases over what ``ease_length`` works out for the verbs the creature plays, at the change
    (from 0.5 to 3 s: a walk going from 0.9 to 1.8 m/s needs more than half a second); ``over`` is taken as given. The
    log and the cue list say how long each took, and the point arrives when the ease is over."""
    from adverbs.apps.scene import cue_lines
    from adverbs.graph.easing import EASE, MOST_EASE, ease_length

    sim = Simulation(cmu, fps=30.0)
    c = sim.add_creature(adverbs={"walk_speed": 0.9}, name="a")
    sim.run(1.0)
    s = c._group.state
    target = cmu.point({**c.adverbs, "walk_speed": 1.8})
    verbs = [s.verb[0]] + ([s.into[0]] if s.active[0] >= 0 else [])
    need = ease_length(cmu, verbs, s.points[0], target)
    c.set_adverbs(walk_speed=1.8)
    assert EASE < need <= MOST_EASE
    assert sim.log[-1]["eased"] == round(need, 6)
    sim.run(need + 0.1)
    assert c.adverbs["walk_speed"] == 1.8
    c.set_adverbs(walk_speed=1.2, over=0.7)
    assert sim.log[-1]["eased"] == 0.7
    lines = cue_lines(sim, "a")
    assert f"adverbs eased in over {need:.2f} s" in lines[0] and "adverbs eased in over 0.70 s" in lines[1], lines


# ----- scripts ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "text, line, field",
    [
        ("seconds = 5\n[[cues]]\nat = 1.0\nperform = 'run'\nadverbs = { turn = }\n", 5, ""),  # not TOML
        ("seconds = 5\n\n[[cues]]\nat = 1.0\nperfrom = 'run'\n", 5, "cues[0].perfrom"),
        ("[[creatures]]\nname = 'a'\n[[creatures]]\nname = 'b'\n[[cues]]\nat = 1\ncreature = 'a'\nperform = 'run'\n[[cues]]\nat = 2\ncreature = 'c'\nperform = 'walk'\n", 11, "cues[1].creature"),
        ("[[creatures]]\nname = 'a'\n[[creatures]]\nname = 'b'\n[[cues]]\nat = 1\nperform = 'run'\n", 5, "cues[0].creature"),
        ("[[cues]]\nat = 1\nperform = 'run'\n[[cues]]\nat = 'soon'\nperform = 'walk'\n", 5, "cues[1].at"),
        ("[[cues]]\nat = 1\nperform = 'run'\nover = -2\n", 4, "cues[0].over"),
        ("[[cues]]\nat = 1\n", 1, "cues[0]"),
        ("[[creatures]]\nname = 'a'\nat = [0, 0, 0]\n", 3, "creatures[0].at"),
        ("[[creatures]]\nname = 'a'\nadverbs = { turn = 'left' }\n", 3, "creatures[0].adverbs.turn"),
        ("fps = 0\n", 1, "fps"),
        ("speed = 2\n", 1, "speed"),
        ("[[cues]]\nat = 1\nperform = 'run'\nstay = 'yes'\n", 4, "cues[0].stay"),
    ],
)
def test_malformed_scripts_are_refused_before_the_run_naming_line_and_field(tmp_path, text, line, field):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ScriptError) as e:
        load_script(path)
    assert e.value.line == line and e.value.field == field
    assert f"bad.toml, line {line}" in str(e.value)


def test_a_script_cue_the_graph_refuses_names_its_line(tmp_path, cmu):
    path = tmp_path / "s.toml"
    path.write_text("seconds = 2\n[[cues]]\nat = 0.5\nperform = 'fly'\n\n[[cues]]\nat = 1.0\nadverbs = { walk_speed = nan }\n")
    script = load_script(path)
    sim = Simulation(cmu)
    script.apply(sim)
    with pytest.warns(AdverbsWarning, match=r"s.toml, line 2: at 0.500 s, creature1: graph 'cmu' has no verb 'fly'"):
        sim.run(script.seconds)
    assert [e["source"].rsplit(" ", 1)[-1] for e in sim.log if e["status"] == "refused"] == ["2", "6"]
    assert sim.frames == 60


def test_feet_planting_is_switched_by_an_event(cmu):
    sim = Simulation(cmu)
    c = sim.add_creature(adverbs={"walk_speed": 1.4})
    sim.set_plant(False, at=1.0)
    sim.set_plant(True, at=2.0)
    free = Simulation(cmu, plant=False)
    f = free.add_creature(adverbs={"walk_speed": 1.4})
    sim.run(3.0)
    free.run(3.0)
    a, b = c.clip().rotations, f.clip().rotations
    assert not np.allclose(a[:29], b[:29], atol=1e-6)  # planted: the legs differ from the verb's own
    np.testing.assert_array_equal(a[30:59], b[30:59])  # frames at 1.0 .. 1.97 s: the verb alone
    assert not np.allclose(a[60:], b[60:], atol=1e-6)
    assert [e["on"] for e in sim.log if e["command"] == "plant"] == [False, True]


def test_a_command_after_the_end_of_a_run_is_reported_not_dropped(cmu, tmp_path):
    sim = Simulation(cmu, fps=30.0)
    c = sim.add_creature()
    c.perform("run", at=0.5)
    c.perform("walk", at=50.0)  # the run below ends at 2 s
    sim.run(2.0)
    arrived = [e for e in sim.log if e["command"] == "arrived"]
    assert arrived and arrived[0]["verb"] == "run" and arrived[0]["time"] >= 0.5  # when the run played alone
    report = sim.report()
    assert [(e["time"], e["verb"], e["status"]) for e in report["not_run"]] == [(50.0, "walk", "not run")]
    sim.run(49.0)  # run on past it: it runs, and is no longer reported as not run
    assert sim.report()["not_run"] == []
    assert any(e["command"] == "perform" and e["verb"] == "walk" and e["time"] == 50.0 for e in sim.log)


def test_a_long_recording_is_kept_on_disk_not_in_memory(cmu):
    """Recorded frames go to disk as the run goes (runtime.recording): a minute more of 20 creatures grows the
    Python heap by well under what keeping the frames would take (20 x 19 joints x 7 x 8 bytes a frame: 38 MB a
    minute at 30 fps), and the clips read back are the frames shown."""
    import tracemalloc

    sim = Simulation(cmu, fps=30.0, seed=2)
    crowd = [sim.add_creature(at=(2.0 * k, 0.0)) for k in range(20)]
    for k, c in enumerate(crowd):
        c.perform("run" if k % 2 else "walk", at=1.0 + 0.1 * k)
    shown = []
    sim.run(5.0, on_frame=lambda s: shown.append(s._groups[next(iter(s._groups))].rotations[3].copy()))
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        sim.run(60.0)
        grown = tracemalloc.get_traced_memory()[0] - before
    finally:
        tracemalloc.stop()
    kept = 60 * 30 * 20 * cmu.skeleton.num_joints * 7 * 8
    assert grown < 0.1 * kept, (grown, kept)
    clip = crowd[3].clip()
    assert clip.num_frames == sim.frames
    np.testing.assert_array_equal(clip.rotations[: len(shown)], np.stack(shown))
    folder = sim._folder.path
    sim.close()
    assert not folder.exists()


def test_a_recording_written_a_block_at_a_time_is_the_whole_clip_byte_for_byte(cmu, tmp_path, monkeypatch):
    """``Simulation.write`` writes each BVH file from the recording on disk a block of frames at a time (Euler angles
    unwrapped on from block to block): the same bytes as the whole clip written at once."""
    from adverbs import write_bvh
    from adverbs.runtime import recording

    monkeypatch.setattr(recording, "READ_BYTES", 3 * 70 * cmu.skeleton.num_joints * 7 * 8)  # blocks of 70 frames
    sim = Simulation(cmu, fps=30.0, seed=4)
    crowd = [sim.add_creature(at=(2.0 * k, 0.0), heading=50.0 * k) for k in range(3)]
    for k, c in enumerate(crowd):
        c.perform("run", at=0.5 + k)
        c.set_adverbs({"turn": 60.0 - 40.0 * k}, at=1.0)  # turning: headings wrap past ±180°
    sim.run(12.0)
    paths = sim.write(tmp_path / "blocks", formats=("bvh", "glb"))
    for c in crowd:
        write_bvh(c.clip(), tmp_path / f"{c.name}.whole.bvh")
        assert paths[c.name].read_bytes() == (tmp_path / f"{c.name}.whole.bvh").read_bytes()
        assert paths[f"{c.name}.glb"].exists()


def test_the_log_of_a_long_run_is_kept_on_disk_and_reads_as_a_list(cmu, tmp_path, monkeypatch):
    """Past a few thousand entries the log goes to disk as JSON lines (runtime.recording.EventLog); it reads back as
    the list it was (iterated, indexed, compared), and events.json is written from it entry by entry."""
    import json

    from adverbs.runtime import recording

    monkeypatch.setattr(recording.EventLog, "IN_MEMORY", 7)
    sim = Simulation(cmu, fps=30.0, seed=3)
    c = sim.add_creature()
    for t in np.arange(0.3, 20.0, 0.7):
        c.perform(["run", "walk"][int(t) % 2], at=float(t))
    sim.run(20.0)
    assert sim.log._on_disk > 0  # spilled
    entries = list(sim.log)
    assert len(sim.log) == len(entries) > 40 and sim.log == entries and sim.log[-1] == entries[-1]
    assert sim.log[3] == entries[3] and sim.log[2:5] == entries[2:5]
    paths = sim.write(tmp_path / "o")
    report = json.loads(paths["events"].read_text())
    assert report["events"] == entries and report["frames"] == sim.frames
    del sim.log[:-10]  # trimmed (the viewer keeps its last entries)
    assert list(sim.log) == entries[-10:]


def test_reports_after_close_a_refused_nan_and_a_cue_whose_adverbs_were_set(cmu, tmp_path, monkeypatch):
    """Found by review: after ``close`` a simulation logs to a new folder (its log file went with the old one); a cue
    refusing a NaN adverb is printed, not a traceback; a verb refused beside adverbs that were set says both."""
    import warnings as w

    from adverbs.apps.scene import cue_lines
    from adverbs.graph import Cue, perform
    from adverbs.runtime import recording

    monkeypatch.setattr(recording.EventLog, "IN_MEMORY", 8)
    sim = Simulation(cmu, fps=30.0)
    c = sim.add_creature()
    for t in np.arange(0.2, 3.0, 0.3):
        c.perform(["run", "walk"][int(10 * t) % 2], at=float(t))
    sim.run(3.0)
    sim.close()
    c.perform("run", at=3.5)
    with w.catch_warnings():
        w.simplefilter("ignore", AdverbsWarning)
        c.set_adverbs({"turn": float("nan")}, at=3.6, over=0.0)
    sim.run(3.0)  # the log spills again, into a new folder
    lines = cue_lines(sim, c.name)
    assert any("turn=nan: refused" in line for line in lines), lines
    perf = perform(cmu, [Cue(1.0, "fly", {"turn": -30.0})], seconds=4.5)  # (an ease is at most 3 s)
    assert perf.cues[0][2].startswith("adverbs set, eased over ") and "; refused: " in perf.cues[0][2]
    assert perf.state.points[0][cmu.adverb_names.index("turn")] == -30.0
