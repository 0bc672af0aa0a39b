"""The verb commands, run as a user runs them."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import SPECS
from test_cli import run

from adverbs import read_bvh
from adverbs.motion.contacts import find_contacts
from adverbs.verb.measures import measure


def test_build_describe_synth_evaluate(tmp_path):
    verb = tmp_path / "walk.verb"
    r = run("build", SPECS / "cmu_walk.toml", "-o", verb)
    assert r.returncode == 0, r.stderr
    assert "built cmu-walk: 12 examples" in r.stdout and verb.exists()

    r = run("describe", verb, "--json")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert [a["name"] for a in d["adverbs"]] == ["speed", "turn"]
    assert d["adverbs"][0]["unit"] == "m/s" and d["adverbs"][1]["unit"] == "deg/s"
    assert len(d["examples"]) == 12 and set(d["examples"][0]["adverbs"]) == {"speed", "turn"}
    assert d["num_keytimes"] == 3 and d["num_cp"] == 16 and d["dofs"] > 50
    assert (d["smoothing"], d["shrinkage"], d["timing"], d["goal_chain"]) == (0.0, 0.0, "extrapolate", [])
    assert run("describe", verb).stdout.startswith("verb cmu-walk: cyclic, 12 examples")

    out = tmp_path / "walk.bvh"
    r = run("synth", verb, "--adverb", "speed=1.5", "--adverb", "turn=-30", "--cycles", "3", "-o", out)
    assert r.returncode == 0, r.stderr
    clip = read_bvh(out)
    assert clip.skeleton.names == tuple(d["skeleton"]["joints"])
    # Three cycles: the feet keep alternating, and the motion turns right at about the asked rate.
    steps = [f for _, f in find_contacts(clip).steps()]
    assert len(steps) >= 5 and all(a != b for a, b in zip(steps, steps[1:]))
    # Read back from the file, over all three cycles: the asked turn rate within 5% of the examples' range.
    turn = measure(clip, np.array([0.0, clip.duration]), {"kind": "turn_rate"})
    assert turn == pytest.approx(-30.0, abs=0.05 * (d["adverbs"][1]["max"] - d["adverbs"][1]["min"]))

    r = run("synth", verb, "--adverb", "speed=1.2", "--duration", "2.5", "--fps", "60", "-o", out)
    assert r.returncode == 0 and read_bvh(out).num_frames == 151

    png = tmp_path / "eval.png"
    r = run("evaluate", verb, "--png", png)
    assert r.returncode == 0, r.stderr
    for method in ("nearest", "linear", "idw", "scipy-rbf", "ours"):
        assert f"| {method} |" in r.stdout
    assert "| speed |" in r.stdout and "25% past" in r.stdout
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_verb_command_errors(tmp_path):
    r = run("build", tmp_path / "none.toml", "-o", tmp_path / "x.verb")
    assert r.returncode == 1 and "no such spec file" in r.stderr
    verb = tmp_path / "walk.verb"
    assert run("build", SPECS / "cmu_walk.toml", "-o", verb).returncode == 0
    r = run("synth", verb, "--adverb", "mood=1", "-o", tmp_path / "x.bvh")
    assert r.returncode == 1 and "no adverb 'mood'" in r.stderr
    r = run("synth", verb, "--adverb", "speed=nan", "-o", tmp_path / "x.bvh")
    assert r.returncode == 2 and "finite" in r.stderr
    (tmp_path / "junk.verb").write_text("junk")
    r = run("describe", tmp_path / "junk.verb")
    assert r.returncode == 1 and "damaged" in r.stderr


def test_synth_plants_feet_by_default_on_any_floor(tmp_path):
    verb = tmp_path / "walk.verb"
    assert run("build", SPECS / "bandai_styled_walk.toml", "-o", verb).returncode == 0
    d = json.loads(run("describe", verb, "--json").stdout)
    assert [c["effector"] for c in d["constraints"]] == ["Toes_L", "Toes_R"]
    assert [h["effector"] for h in d["holds"]] == ["Toes_L", "Toes_R"]
    assert all(h["open"] < h["toe_down"] < h["heel_off"] < h["close"] and 0.03 < h["height"] < 0.06 for h in d["holds"])
    args = ["synth", verb, "--adverb", "valence=0.5", "--adverb", "turn=20", "--cycles", "2"]
    r = run(*args, "-o", tmp_path / "ik.bvh")
    assert r.returncode == 0 and "feet planted: toe drift median 0.0 / max 0.0 mm" in r.stdout, r.stdout
    assert "lowest +0.0 mm" in r.stdout or "lowest -0.0 mm" in r.stdout, r.stdout
    r = run(*args, "--no-ik", "-o", tmp_path / "raw.bvh")
    assert r.returncode == 0 and "--no-ik" in r.stdout
    ik, raw = read_bvh(tmp_path / "ik.bvh"), read_bvh(tmp_path / "raw.bvh")
    assert np.abs(ik.global_positions() - raw.global_positions()).max() > 1e-2  # IK moves some joint over 1 cm
    r = run(*args, "--floor", "slope:10", "-o", tmp_path / "up.bvh")
    assert r.returncode == 0, r.stderr
    up = read_bvh(tmp_path / "up.bvh").global_positions()[:, 1]  # Hips
    assert up[-1, 1] - up[0, 1] > 0.2  # it walked uphill
    x, z = np.meshgrid(np.arange(40) * 0.25 - 5, np.arange(40) * 0.25 - 5)
    np.savez(tmp_path / "bumps.npz", heights=0.05 * np.sin(x) * np.cos(z), spacing=0.25, origin=np.array([-5.0, -5.0]))
    r = run(*args, "--floor", tmp_path / "bumps.npz", "-o", tmp_path / "bumps.bvh")
    assert r.returncode == 0, r.stderr
    r = run(*args, "--floor", tmp_path / "missing.npz", "-o", tmp_path / "x.bvh")
    assert r.returncode == 1 and "no such height map" in r.stderr


def test_floor_needs_planted_feet_and_evaluate_handles_two_examples(tmp_path):
    verb = tmp_path / "w.verb"
    assert run("build", SPECS / "cmu_walk.toml", "-o", verb).returncode == 0
    r = run("synth", verb, "--no-ik", "--floor", "slope:10", "-o", tmp_path / "x.bvh")
    assert r.returncode == 1 and "--no-ik" in r.stderr
    spec = tmp_path / "two.toml"
    spec.write_text(
        'name = "two"\nnum_cp = 10\ncut = { foot = "left", steps = 2 }\n[[adverbs]]\nname = "speed"\nmeasure = "speed"\n'
        f'[[examples]]\nname = "a"\nfile = "{SPECS.parent / "data/cmu16/16_15_walk.bvh"}"\n'
        f'[[examples]]\nname = "b"\nfile = "{SPECS.parent / "data/cmu16/16_21_walk.bvh"}"\n'
    )
    assert run("build", spec, "-o", tmp_path / "two.verb").returncode == 0
    r = run("evaluate", tmp_path / "two.verb")
    assert r.returncode == 0, r.stderr
    assert "| ours | n/a | n/a |" in r.stdout and "| nearest |" in r.stdout


def test_a_verb_of_one_example_builds_plays_it_and_refuses_leave_one_out(tmp_path):
    spec = tmp_path / "bow.toml"
    bow = SPECS.parent / "data/bandai/dataset-1_bow_normal_001.bvh"
    spec.write_text(
        f'name = "bow"\ncyclic = false\nnum_cp = 32\n[[examples]]\nname = "bow"\nfile = "{bow}"\n'
        "frames = [0, 138]\nkeytimes = [0.0, 4.5666667]\n"
    )
    verb = tmp_path / "bow.verb"
    r = run("build", spec, "-o", verb)
    assert r.returncode == 0 and "1 examples, 0 adverbs" in r.stdout, r.stderr
    r = run("synth", verb, "-o", tmp_path / "bow.bvh")
    assert r.returncode == 0 and "bow at its one example; 138 frames" in r.stdout, r.stderr
    r = run("synth", verb, "--no-ik", "-o", tmp_path / "free.bvh")
    played, source = read_bvh(tmp_path / "free.bvh").rotations[:, 2:], read_bvh(bow).rotations[:138, 2:]
    # It plays its example: every joint below the hips turned as the take turns it, within the fit's error.
    angle = 2 * np.degrees(np.arccos(np.clip(np.abs(np.sum(played * source, axis=-1)), 0, 1)))
    assert np.median(angle) < 0.5 and angle.max() < 5.0, (np.median(angle), angle.max())
    r = run("evaluate", verb)
    assert r.returncode == 1 and "has 1 example(s) and 0 adverb(s)" in r.stderr
