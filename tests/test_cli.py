"""The command line, run as a user runs it: a real process on real files."""

from __future__ import annotations

import json
import resource
import subprocess
from pathlib import Path
import sys

import numpy as np
from conftest import BANDAI, CMU

from adverbs import read_bvh


def run(*args, limits: dict[int, int] | None = None, timeout: float | None = None):
    """``adverbs ARGS`` in a child process; ``limits``: resource limits it runs under (``{resource.RLIMIT_AS: n}``)."""

    def cap():
        for kind, n in limits.items():
            resource.setrlimit(kind, (n, n))

    return subprocess.run(
        [sys.executable, "-m", "adverbs", *map(str, args)], capture_output=True, text=True, check=False,
        preexec_fn=cap if limits else None, timeout=timeout,
    )  # fmt: skip


def test_info_json():
    r = run("info", CMU / "16_15_walk.bvh", "--json")
    assert r.returncode == 0, r.stderr
    report = json.loads(r.stdout)
    assert report["frames"] == 117 and report["fps"] == 30 and report["units"] == "cm"
    assert len(report["joints"]) == 19 and report["joints"][0]["name"] == "pelvis"
    assert report["joints"][1]["channels"] == ["Zrotation", "Xrotation", "Yrotation"]
    assert set(report["feet"]) == {"left", "right"}
    assert report["feet"]["left"]["ankle"] == "lfoot" and report["feet"]["left"]["contacts"]


def test_info_text():
    r = run("info", BANDAI / "dataset-1_walk_sad_001.bvh")
    assert r.returncode == 0, r.stderr
    assert "347 frames at 30 fps" in r.stdout and "left foot (Foot_L, toe Toes_L)" in r.stdout


def test_convert_frames_mirror_fps(tmp_path):
    src = CMU / "16_19_walk_90-degree_right_turn.bvh"
    out = tmp_path / "sub" / "left.bvh"
    r = run("convert", src, out, "--frames", "10:70", "--mirror", "--fps", "60")
    assert r.returncode == 0, r.stderr
    clip, done = read_bvh(src), read_bvh(out)
    expected = clip.frames(10, 70).mirror().resample(60)
    assert done.fps == 60 and done.num_frames == expected.num_frames == 119
    np.testing.assert_allclose(done.global_positions(), expected.global_positions(), rtol=0, atol=1e-6)


def test_errors_name_the_file_and_line_and_exit_1(tmp_path):
    bad = tmp_path / "bad.bvh"
    bad.write_text((CMU / "16_21_walk.bvh").read_text().replace("CHANNELS 3 Zrotation", "CHANNELS 3 Qrotation", 1))
    r = run("info", bad)
    assert r.returncode == 1 and f"{bad}:" in r.stderr and "Qrotation" in r.stderr
    r = run("convert", CMU / "16_21_walk.bvh", tmp_path / "x.bvh", "--frames", "50:10")
    assert r.returncode == 1 and "empty" in r.stderr
    r = run("convert", CMU / "16_21_walk.bvh", tmp_path / "x.bvh", "--fps", "-3")
    assert r.returncode == 2 and "positive" in r.stderr


def test_outputs_that_cannot_be_written_and_bad_floors(tmp_path):
    r = run("convert", CMU / "16_21_walk.bvh", tmp_path)  # a directory
    assert r.returncode == 1 and "adverbs: error:" in r.stderr and "Traceback" not in r.stderr
    verb = tmp_path / "w.verb"
    assert run("build", Path(__file__).parent.parent / "specs" / "cmu_walk.toml", "-o", verb).returncode == 0
    for floor in ("flat:nan", "slope:95"):
        r = run("synth", verb, "--floor", floor, "-o", tmp_path / "x.bvh")
        assert r.returncode == 1 and "Traceback" not in r.stderr, r.stderr
    np.savez(tmp_path / "odd.npz", heights=np.zeros((4, 4)), spacing=np.array([0.5, 0.5]))
    r = run("synth", verb, "--floor", tmp_path / "odd.npz", "-o", tmp_path / "x.bvh")
    assert r.returncode == 1 and "spacing must be one number" in r.stderr
