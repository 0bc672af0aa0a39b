"""The main job and its pictures: `adverbs demo`, `adverbs run`, `adverbs render`, and the BVH it writes opened in
Blender's own importer where Blender is installed."""

from __future__ import annotations

import json
import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from adverbs import AdverbsError, load_graph, read_bvh
from adverbs.apps import blender
from adverbs.apps.cli import main
from adverbs.apps.render import render
from adverbs.apps.scene import DEMO_SCRIPT, run_script
from adverbs.errors import AdverbsWarning
from adverbs.runtime import Simulation
from adverbs.runtime.script import load_script

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    """The demo's scenario, its first 6 seconds: a Bandai and a CMU creature, feet planted."""
    out = tmp_path_factory.mktemp("scene")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        sim, paths = run_script([], DEMO_SCRIPT, out, seconds=6.0, quiet=True)
    return sim, paths


def test_the_demo_scene_has_both_creatures_doing_what_the_script_says(scene):
    sim, paths = scene
    assert {c.name: c.graph.name for c in sim.creatures} == {"bandai": "bandai", "cmu": "cmu"}
    for name in ("bandai", "cmu"):
        clip = read_bvh(paths[name])
        assert clip.num_frames == 180
        pos = clip.global_positions()
        assert np.all(np.isfinite(pos))
        assert pos[..., 1].min() > -0.005  # nothing below the floor
    log = json.loads(paths["events"].read_text())
    walk = [e for e in log["events"] if e["creature"] == "bandai" and e["command"] == "transition" and e["to"] == "walk"]
    assert walk and walk[0]["from"] == "idle" and 1.0 <= walk[0]["time"] < 2.5  # asked at 1 s, on its way soon after
    assert not [e for e in log["events"] if e["status"] == "refused"]


@pytest.mark.skipif(blender.blender() is None, reason="Blender is not installed here (Debian: apt-get install blender)")
def test_blender_imports_the_scene_with_our_frames_and_joint_positions(scene):
    _, paths = scene
    for name in ("bandai", "cmu"):
        r = blender.compare(paths[name])
        clip = read_bvh(paths[name])
        assert r["blender_frames"] == r["frames"] == clip.num_frames
        assert r["joints"] == clip.skeleton.num_joints and r["blender_fps"] == pytest.approx(clip.fps)
        # Blender keeps positions in 32-bit floats: 0.1 mm is a few of their steps at the scene's size
        assert r["max_difference_m"] <= 1e-4, r


def _frames(path):
    im = Image.open(path)
    out = []
    for k in range(getattr(im, "n_frames", 1)):
        im.seek(k)
        out.append(np.asarray(im.convert("RGB")))
    return out


def test_render_draws_the_figures_where_they_are(scene, tmp_path):
    _, paths = scene
    clips = [read_bvh(paths["bandai"]), read_bvh(paths["cmu"])]
    gif = render(clips, tmp_path / "scene.gif", fps=5, size=(320, 200), split=True)
    frames = _frames(gif)
    assert len(frames) == 30  # frames at 1/30 .. 6 s: 5.97 s at 5 fps
    for f in frames:
        dark = f.min(axis=-1) < 120  # the bones (the grid is light grey, the floor white)
        cols = np.flatnonzero(dark.any(axis=0))
        assert dark.sum() > 100 and cols.min() < 160 < cols.max()  # a figure in each half
    png = render(clips[:1], tmp_path / "strip.png", panels=4, size=(320, 240))
    strip = np.asarray(Image.open(png).convert("RGB"))
    assert strip.std() > 5
    mp4 = render(clips[:1], tmp_path / "one.mp4", fps=10, size=(200, 160))
    import imageio.v2 as imageio

    with imageio.get_reader(mp4) as r:
        assert sum(1 for _ in r) == 60


def test_render_refuses_what_it_cannot_draw(scene, tmp_path):
    _, paths = scene
    clip = read_bvh(paths["cmu"])
    with pytest.raises(AdverbsError, match="gif, .mp4, .png"):
        render([clip], tmp_path / "x.jpg")
    with pytest.raises(AdverbsError, match="camera"):
        render([clip], tmp_path / "x.png", view="sideways")
    (tmp_path / "keep.gif").write_bytes(b"GIF89a-old")
    with pytest.raises(AdverbsError, match="fps"):
        render([clip], tmp_path / "keep.gif", fps=-1)
    assert (tmp_path / "keep.gif").read_bytes() == b"GIF89a-old"


def test_cli_run_and_render(tmp_path, capsys):
    script = tmp_path / "s.toml"
    script.write_text("seconds = 2\n[[cues]]\nat = 0.5\nperform = 'run'\n[[cues]]\nat = 1.0\nperform = 'fly'\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        assert main(["run", str(ROOT / "graphs" / "cmu.toml"), "--script", str(script), "--out", str(tmp_path / "o"), "--seed", "2"]) == 0
    out = capsys.readouterr()
    assert "creature1 (cmu): walk → run;" in out.out
    assert re.search(r"0\.50 s  run: run playing alone at [\d.]+ s", out.out), out.out  # every cue, and what became of it
    assert "1.00 s  fly: refused: graph 'cmu' has no verb 'fly'" in out.out
    assert read_bvh(tmp_path / "o" / "creature1.bvh").num_frames == 60
    assert main(["render", str(tmp_path / "o" / "creature1.bvh"), "-o", str(tmp_path / "c.png"), "--panels", "3", "--camera", "side"]) == 0
    assert (tmp_path / "c.png").exists()
    bvh = str(tmp_path / "o" / "creature1.bvh")
    assert main(["render", bvh, "-o", str(tmp_path / "d.png"), "--panels", "2", "--floor", "slope:5"]) == 0
    assert main(["render", bvh, "-o", str(tmp_path / "e.png"), "--floor", "slope:95"]) == 1
    assert "--floor 'slope:95'" in capsys.readouterr().err and not (tmp_path / "e.png").exists()
    bad = tmp_path / "bad.toml"
    bad.write_text("seconds = 2\n[[cues]]\nat = 'noon'\nperform = 'run'\n")
    assert main(["run", str(ROOT / "graphs" / "cmu.toml"), "--script", str(bad), "--out", str(tmp_path / "p")]) == 1
    err = capsys.readouterr().err
    assert "bad.toml, line 3: cues[0].at: must be a number" in err
    assert not (tmp_path / "p").exists()  # refused before anything ran


def test_demo_writes_its_files(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    for name in ("bandai.bvh", "cmu.bvh", "bandai.glb", "cmu.glb", "events.json", "demo.gif", "demo.png", "report.json"):
        assert (tmp_path / name).stat().st_size > 0 and str(tmp_path / name) in printed
    report = json.loads((tmp_path / "report.json").read_text())
    played = report["summary"][0]
    for verb in ("walk", "run", "reach", "bow", "idle"):
        assert verb in played
    cmu = [line for line in report["summary"] if line.startswith("cmu (cmu): ")]
    assert len(cmu) == 1 and "run" in cmu[0]
    assert any("playing alone at" in line for line in report["summary"])  # each cue and what became of it
    assert len(_frames(tmp_path / "demo.gif")) == 340  # 33.97 s at 10 fps


def test_the_run_figure_colours_each_path_by_the_verb_playing(scene, tmp_path):
    from adverbs.apps.figures import run_figure, shade, timeline

    sim, paths = scene
    log = json.loads(paths["events"].read_text())
    # the log says when each creature's recording starts and how long each blend lasts
    assert [c["recorded_from"] for c in log["creatures"]] == [pytest.approx(sim.frame_times[0])] * 2
    changes = [e for e in log["events"] if e["command"] == "transition" and e["from"] != e["to"]]
    assert changes and all(0.1 < e["seconds"] < 3.0 for e in changes)
    walk = next(e for e in changes if e["creature"] == "bandai")
    line = timeline([e for e in log["events"] if e["creature"] == "bandai" and e["command"] == "transition"], "idle")
    colour = {"idle": np.array([1.0, 0, 0]), "walk": np.array([0, 0, 1.0])}
    t = np.array([walk["time"] - 0.01, walk["time"] + walk["seconds"] / 2, walk["time"] + walk["seconds"] + 0.01])
    np.testing.assert_allclose(shade(t, line, colour), [[1, 0, 0], [0.5, 0, 0.5], [0, 0, 1]], rtol=0, atol=0.02)

    out = run_figure(paths["events"].parent, tmp_path / "run.png")
    pixels = np.asarray(Image.open(out).convert("RGB"))
    has = lambda hex_: int((np.abs(pixels.astype(int) - [int(hex_[i : i + 2], 16) for i in (1, 3, 5)]).max(-1) < 30).sum())  # noqa: E731
    assert has("#1f77b4") > 300 and has("#ff7f0e") > 300  # idle (the first verb seen) and walk, in tab10's first two


def test_the_run_figure_names_what_is_missing(scene, tmp_path):
    from adverbs.apps.figures import run_figure

    _, paths = scene
    with pytest.raises(AdverbsError, match="no such file"):
        run_figure(tmp_path, tmp_path / "x.png")
    (tmp_path / "events.json").write_text(paths["events"].read_text())
    with pytest.raises(AdverbsError, match=r"'bandai' has no recording beside it \(bandai.bvh"):
        run_figure(tmp_path, tmp_path / "x.png")
    (tmp_path / "events.json").write_text('{"creatures": [}')
    with pytest.raises(AdverbsError, match="events.json: not a run log"):
        run_figure(tmp_path / "events.json", tmp_path / "x.png")
    assert not (tmp_path / "x.png").exists()
    assert main(["figure", str(paths["events"].parent), "-o", str(tmp_path / "y.png"), "--kind", "poses"]) != 0
    assert main(["figure", str(paths["events"].parent), "-o", str(tmp_path / "y.png")]) == 0
    assert (tmp_path / "y.png").stat().st_size > 10_000


def _colour(image, rgb, tol=40):
    return np.all(np.abs(image.astype(int) - np.array(rgb)) < tol, axis=-1)


def test_render_draws_the_ground_the_feet_were_planted_on(verbs, tmp_path):
    """A walk planted up a 10° slope, drawn from the side over that slope: in every panel the orange contact dots
    and the floor grid are right under the feet. Drawn over a level floor (what render did before it took a
    floor), the dots and grid stay at height 0 while the walker climbs out of their sight."""
    from adverbs.kinematics.floor import SlopeFloor
    from adverbs.feet.offline import plant_feet

    verb, _ = verbs["cmu_walk"]
    p = verb.points.mean(axis=0)
    clip, k = verb.synthesize(p, cycles=6)
    up, _ = plant_feet(verb, clip, k, SlopeFloor(10.0), p)
    assert up.global_positions()[-1, 0, 1] > 1.0  # it climbed a metre: a level floor at 0 is far below
    png = render([up], tmp_path / "up.png", view="side", panels=4, size=(320, 240), floor=SlopeFloor(10.0))
    strip = np.asarray(Image.open(png).convert("RGB"))
    panels = np.array_split(strip, 4, axis=1)
    for i, panel in enumerate(panels):
        limbs = _colour(panel, (31, 119, 180)) | _colour(panel, (214, 39, 40))  # left blue, right red
        dots = _colour(panel, (255, 127, 14))
        grid = _colour(panel, (217, 217, 217), tol=12)
        rows, cols = np.nonzero(limbs)
        foot_row = rows.max()  # the lowest limb pixel: a foot
        assert dots.sum() > 10, f"panel {i}: no contact dot drawn"
        dr, dc = np.nonzero(dots)
        # every dot within 8 % of the panel's height of a limb pixel
        near = np.hypot(dr[:, None] - rows[None], dc[:, None] - cols[None]).min(axis=1)
        assert near.max() < 0.08 * panel.shape[0], (i, near.max())
        # the grid runs by the lowest foot: within 8 % of the panel's height of it (a metre up the slope is 40 %)
        h, c = int(0.08 * panel.shape[0]), int(cols[rows == foot_row].mean())
        assert grid[foot_row - h : foot_row + h, c - h : c + h].any(), f"panel {i}: no floor grid by the feet"


def test_run_interrupted_keeps_what_it_recorded_and_refuses_options_it_would_ignore(tmp_path, capsys):
    import signal
    import subprocess
    import sys
    import time

    script = tmp_path / "long.toml"
    script.write_text("seconds = 600\n[[cues]]\nat = 1.0\nperform = 'run'\n")
    out = tmp_path / "o"
    cmd = [sys.executable, "-m", "adverbs", "run", str(ROOT / "graphs" / "cmu.toml"), "--script", str(script), "--out", str(out), "--realtime"]
    # (Ctrl-C's default: a shell's background job, `make test &`, starts its children with SIGINT ignored, and Python
    # then installs no handler for it)
    restore = lambda: signal.signal(signal.SIGINT, signal.SIG_DFL)  # noqa: E731
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=restore)
    time.sleep(12)  # the graph built (a few seconds) and some seconds of motion played
    assert proc.poll() is None
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "interrupted at" in err and "wrote what was recorded" in err
    clip = read_bvh(out / "creature1.bvh")  # whole: read back, every frame recorded (kept on disk as it ran)
    report = json.loads((out / "events.json").read_text())  # whole: valid JSON
    assert clip.num_frames > 10 and abs(clip.num_frames / clip.fps - report["seconds"]) < 0.2
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no partial file left beside them
    for extra, said in ((["--no-ik", "--floor", "slope:20"], "--no-ik"), (["--format", "glb", "--portable"], "--portable")):
        assert main(["run", str(ROOT / "graphs" / "cmu.toml"), "--script", str(script), "--out", str(tmp_path / "p"), *extra]) == 1
        assert said in capsys.readouterr().err and not (tmp_path / "p").exists()


def test_the_planter_s_holds_are_recorded_and_measure_the_feet(scene):
    """Creature.holds: the phases the planter held each foot, frame for frame with the clip; over them the held toes
    stay put and never go below the floor (what the demo's report prints)."""
    from adverbs.feet.measures import measure_feet

    sim, _ = scene
    for c in sim.creatures:
        clip, report = c.clip(), c.holds()
        assert len(report.root_drop) == clip.num_frames
        assert all(report.phases) and all(report.flat)  # each foot held, and flat, at some time
        verb = next(v for v in c.graph.verbs if v.holds)
        m = measure_feet(verb, clip, report, sim.floor)
        assert m.toe_drift.max() <= 0.001 and m.lowest > -0.001, m.line()


def test_the_demo_filmstrip_shows_every_verb_its_creature_was_told_to_perform(tmp_path):
    """The filmstrip's panels fall inside each commanded verb's time playing alone (the bow of the demo was between
    two evenly spaced panels), with the start and the end."""
    from adverbs.apps.scene import _panel_times

    script = load_script(DEMO_SCRIPT)
    graphs = [load_graph(ROOT / "graphs" / f"{n}.toml") for n in ("bandai", "cmu")]
    sim = Simulation(graphs, fps=30.0, seed=script.seed, record=False)
    script.apply(sim)
    sim.run(script.seconds)
    times = _panel_times(sim, "bandai")
    arrived = [(e["time"], e["verb"]) for e in sim.log if e["creature"] == "bandai" and e["command"] == "arrived"]
    assert times[0] == 0.0 and times[-1] == pytest.approx(sim.time) and len(times) == len(arrived) + 2
    ends = [t for t, _ in arrived[1:]] + [sim.time]
    for (start, verb), end, t in zip(arrived, ends, times[1:-1]):
        assert start < t < end, (verb, start, t, end)
    assert "bow" in [v for _, v in arrived]
