"""``adverbs graph``, run as a user runs it: a real process on the shipped graph specs and real capture."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

from adverbs import read_bvh

ROOT = Path(__file__).resolve().parent.parent
CMU_GRAPH = ROOT / "graphs" / "cmu.toml"
SPECS = ROOT / "specs"


def run(*args):
    return subprocess.run(
        [sys.executable, "-m", "adverbs", "graph", *map(str, args)], capture_output=True, text=True, check=False
    )


def test_describe_names_the_verbs_the_added_loops_and_what_is_reached():
    r = run(CMU_GRAPH)  # --describe is the default
    assert r.returncode == 0, r.stderr
    out = r.stdout
    assert "graph cmu" in out and "start in walk" in out
    assert re.search(r"^\s+walk\s+cyclic\s+12 examples; takes walk_speed, turn; ignores run_speed", out, re.M), out
    assert re.search(r"^\s+run\s+cyclic\s+13 examples; takes run_speed, turn; ignores walk_speed", out, re.M), out
    assert re.search(r"^\s+walk_speed = 1\.3\s+taken by walk$", out, re.M), out
    lines = {m[1]: m[0] for m in re.finditer(r"^\s+(\w+ → \w+)\s+from_region.*$", out, re.M)}
    assert set(lines) == {"walk → run", "run → walk", "walk → walk", "run → run"}
    assert "added" in lines["walk → walk"] and "added" in lines["run → run"]
    assert "added" not in lines["walk → run"] and "from_region [0.48, 0.73]" in lines["run → walk"]
    assert "arms carried past the blend" in lines["walk → run"] and "arms" not in lines["walk → walk"]
    assert "every verb can be reached from the start verb walk" in out
    assert "loading graph" in r.stderr and "built verb 'cmu-walk'" in r.stderr  # progress, not in stdout


def test_json_round_trips_with_the_transitions():
    r = run(CMU_GRAPH, "--json")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["name"] == "cmu" and d["start"] == "walk" and [v["name"] for v in d["verbs"]] == ["walk", "run"]
    ways = {(t["from"], t["to"]): t for t in d["transitions"]}
    assert set(ways) == {("walk", "run"), ("run", "walk"), ("walk", "walk"), ("run", "run")}
    assert ways["walk", "walk"]["added"] and not ways["walk", "run"]["added"]
    assert ways["walk", "run"]["from_region"] == [0.0, 0.25] and ways["walk", "walk"]["likelihood"] == 3.0


def test_plan_prints_the_path_or_refuses_naming_the_verbs():
    r = run(CMU_GRAPH, "--plan", "walk", "run")
    assert r.returncode == 0, r.stderr
    lines = r.stdout.strip().splitlines()
    assert len(lines) == 2, r.stdout
    assert lines[0].startswith("walk → run  (from_region [0.00, 0.25] to_region [0.00, 0.25]")
    assert lines[1] == "1 transition from walk to run"
    r = run(CMU_GRAPH, "--plan", "walk", "nowhere")
    assert r.returncode == 1 and r.stdout == ""
    assert "adverbs: error:" in r.stderr and "'nowhere'" in r.stderr and "walk, run" in r.stderr
    assert "Traceback" not in r.stderr


def test_malformed_cues_and_misplaced_options_are_refused_before_any_work(tmp_path):
    out = tmp_path / "x.bvh"
    for script, named in (("1:run,4.5turn=30", "'4.5turn=30'"), ("1:run,x:walk", "'x:walk'")):
        r = run(CMU_GRAPH, "--play", script, "-o", out)
        assert r.returncode == 2 and f"cue {named}" in r.stderr, r.stderr
        assert "loading graph" not in r.stderr  # nothing was built
    r = run(CMU_GRAPH, "--play", "1:run,,4:walk", "-o", out)
    assert r.returncode == 2 and "empty cue" in r.stderr
    r = run(CMU_GRAPH, "--seconds", "3")
    assert r.returncode == 2 and "--seconds goes with --play" in r.stderr
    assert not out.exists()


def test_play_writes_the_planted_performance(tmp_path):
    out = tmp_path / "sub" / "walk_run_walk.bvh"
    # Seed 3: after arriving in the run the creature loops in it until told to walk (other seeds may wander
    # back to the walk by themselves before 4 s; the commands guarantee only that each verb is reached).
    r = run(CMU_GRAPH, "--play", "0.5:run,4:walk", "--seconds", "6", "--seed", "3", "-o", out)
    assert r.returncode == 0, r.stderr
    clip = read_bvh(out)
    assert clip.num_frames == 180 and clip.fps == 30
    line, *cues = r.stdout.strip().splitlines()  # one line of what played, then every cue and what became of it
    assert line.startswith(f"wrote {out}: 180 frames at 30 fps = 6.00 s; ")
    assert cues[0] == "cues:" and len(cues) == 3, cues
    assert re.match(r"\s+0\.50 s  run: run playing alone at [\d.]+ s \([\d.]+ s later\)$", cues[1]), cues
    assert re.match(r"\s+4\.00 s  walk: walk (playing alone at [\d.]+ s|playing already)", cues[2]), cues
    assert re.search(r"played walk → .*run → .*walk", line), line
    latencies = re.search(r"command latencies: run ([\d.]+) s, walk ([\d.]+) s;", line)
    assert latencies, line
    assert 0 < float(latencies[1]) < 2 and 0 <= float(latencies[2]) < 2
    assert "feet planted: toe drift median" in line and "out of reach" in line
    assert "refused" not in r.stderr and "playing 6 s at 30 fps" in r.stderr


def test_play_warns_of_refused_commands_and_goes_on(tmp_path):
    out = tmp_path / "x.bvh"
    r = run(CMU_GRAPH, "--play", "0.5:fly,1:wings=2,9:run", "--seconds", "2", "-o", out)
    assert r.returncode == 0, r.stderr
    assert "adverbs: warning: command at 0.5 s refused:" in r.stderr and "no verb 'fly'" in r.stderr
    assert "adverbs: warning: command at 1 s refused:" in r.stderr and "no adverb 'wings'" in r.stderr
    assert "cue 9:run comes after the last frame" in r.stderr
    assert read_bvh(out).num_frames == 60 and "played walk;" in r.stdout and "no verb commands" in r.stdout


def test_graph_spec_errors_name_the_file_and_field(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(
        f'name = "bad"\n[[verbs]]\nname = "walk"\nspec = "{(SPECS / "cmu_walk.toml").as_posix()}"\n'
        '[[transitions]]\nfrom = "walk"\nto = "fly"\nfrom_region = [0.0, 0.25]\nto_region = [0.0, 0.25]\n'
    )
    r = run(bad)
    assert r.returncode == 1 and "Traceback" not in r.stderr
    assert f"adverbs: error: {bad}: field 'transitions[1].to': unknown verb 'fly'" in r.stderr, r.stderr


def test_describe_says_what_the_start_verb_cannot_reach(tmp_path):
    one_way = tmp_path / "one_way.toml"  # nothing leads from the walk to the run
    one_way.write_text(
        f'name = "one-way"\nstart = "walk"\n'
        f'[[verbs]]\nname = "walk"\nspec = "{(SPECS / "cmu_walk.toml").as_posix()}"\nadverbs = {{ speed = "walk_speed" }}\n'
        f'[[verbs]]\nname = "run"\nspec = "{(SPECS / "cmu_run.toml").as_posix()}"\nadverbs = {{ speed = "run_speed" }}\n'
        '[[transitions]]\nfrom = "run"\nto = "walk"\nfrom_region = [0.48, 0.73]\nto_region = [0.48, 0.73]\n'
    )
    r = run(one_way)
    assert r.returncode == 0, r.stderr
    assert "warning: run cannot be reached from the start verb walk" in r.stdout
    assert re.search(r"from walk reaches walk \(not run\)", r.stdout), r.stdout


def test_play_reports_every_cue_none_dropped_silently():
    """Each cue of ``graph --play`` is reported with its time and what became of it: played (when), refused (why),
    superseded by a later cue before its verb played, or after the last frame."""
    import warnings

    from adverbs import load_graph, perform
    from adverbs.errors import AdverbsWarning
    from adverbs.graph import Cue

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        graph = load_graph(CMU_GRAPH)
    cues = [Cue(0.5, "run"), Cue(0.6, "walk"), Cue(1.0, "fly"), Cue(2.0, adverbs={"turn": 20.0}), Cue(9.0, "run")]
    perf = perform(graph, cues, seconds=4.0, seed=1)
    assert [t for t, _, _ in perf.cues] == [0.5, 0.6, 1.0, 2.0, 9.0]  # every cue, in time order
    outcome = {t: o for t, _, o in perf.cues}
    assert outcome[0.5].startswith("superseded by the cue at 0.6 s") or "playing" in outcome[0.5]
    assert outcome[0.6].startswith("walk playing")
    assert outcome[1.0].startswith("refused: ") and "fly" in outcome[1.0]
    assert outcome[2.0].startswith("adverbs set, eased over ") and outcome[2.0].endswith(" s")
    assert outcome[9.0].startswith("not played: after the last frame")
    assert len(perf.cue_lines()) == len(cues)
