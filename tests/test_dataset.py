"""Motion datasets (issue 34): the same bytes on one process and on a two-worker Dask cluster, verbs and graphs shipped
once as data, a killed worker or a killed run losing no finished shard, bad specs refused before any work, and the
arrays and manifest read back. Real verbs and graphs from the shipped specs; the clusters listen on 127.0.0.1 only."""

from __future__ import annotations

import hashlib
import json
import logging
import math
import os
import signal
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from test_cli import run

import adverbs
from adverbs import read_bvh
from adverbs.dataset import SCHEMA, DatasetSpecError, load_dataset_spec, run as runner, sources
from adverbs.dataset.plan import draw_points

ROOT = Path(__file__).resolve().parent.parent
SPEC = f"""
name = "tiny"
seed = 11
formats = ["arrays", "bvh", "glb"]
shard_size = 3
floors = ["flat", "slope:4"]

[[verbs]]
spec = "{ROOT / "specs/cmu_walk.toml"}"
clips = 5
sampler = "sobol"
margin = 0.1
duration = [1.0, 2.0]

[[verbs]]
spec = "{ROOT / "specs/bandai_bow.toml"}"
clips = 1

[[verbs]]
spec = "{ROOT / "specs/cmu_walk.toml"}"
name = "cmu-walk-far"
sampler = "points"
points = [{{ speed = 1.2, turn = 0 }}, {{ speed = 1.2, turn = -1e4 }}]

[[graphs]]
graph = "{ROOT / "graphs/cmu.toml"}"
clips = 3
sampler = "lhs"
duration = [2.0, 3.0]
every = [0.8, 1.5]
"""
CLIPS, SHARDS = 11, 4


def _spec(folder: Path, text: str = SPEC) -> Path:
    path = folder / "spec.toml"
    path.write_text(text)
    return path


def _files(folder: Path) -> dict[str, str]:
    """Every file of a dataset folder but the copy of its spec, by path: its SHA-256."""
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and p.name != "spec.toml"
    }


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The tiny dataset made in this process, no cluster: what every other way of making it must equal."""
    folder = tmp_path_factory.mktemp("reference")
    summary = adverbs.dataset(_spec(folder), folder / "ds", workers=0)
    assert summary.complete and summary.clips == CLIPS and summary.shards == SHARDS
    assert summary.failed == 1  # turn = -1e4 asks for a 23-minute cycle: recorded, the rest go on
    return folder / "ds"


@pytest.fixture(scope="module")
def cluster():
    from distributed import Client, LocalCluster

    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None,
        silence_logs=logging.ERROR, scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
    ) as c, Client(c) as client:  # fmt: skip
        yield c, client


def test_the_same_bytes_on_one_process_and_on_a_two_worker_cluster(reference, cluster, tmp_path, monkeypatch):
    c, client = cluster
    built = []
    real = sources.build_from_spec
    monkeypatch.setattr(sources, "build_from_spec", lambda *a: built.append(a) or real(*a))
    before = client.run(sources.load_counts)
    summary = adverbs.dataset(_spec(tmp_path), tmp_path / "ds", scheduler=c.scheduler_address)
    assert summary.complete and summary.workers == 2 and summary.made + summary.failed == CLIPS
    assert _files(tmp_path / "ds") == _files(reference)
    # Built once, here: one verb spec (the walk, named twice) and the graph's; each worker loads each source at most
    # once from the bytes it was sent, whatever the number of shards it makes.
    assert len(built) == 2
    after = client.run(sources.load_counts)
    assert len(after) == 2
    for worker, counts in after.items():
        assert counts["verb"] - before[worker]["verb"] <= 3 and counts["graph"] - before[worker]["graph"] <= 1


def test_a_killed_worker_loses_no_finished_shard_and_a_rerun_completes(reference, cluster, tmp_path):
    c, client = cluster
    out = tmp_path / "ds"
    kept: dict[str, str] = {}

    def kill_a_worker(result):
        if kept:
            return
        marker = json.loads((out / f"shards/{result.shard:06d}/done.json").read_text())
        kept.update({rel: e["sha256"] for rel, e in marker["files"].items()})
        pid = next(iter(client.run(os.getpid).values()))
        os.kill(pid, signal.SIGKILL)  # mid-run: other shards are under way or waiting

    first = adverbs.dataset(_spec(tmp_path), out, scheduler=c.scheduler_address, on_shard=kill_a_worker)
    assert kept and first.made + first.failed + sum(1 for _ in first.shard_errors) > 0
    for rel, digest in kept.items():
        assert hashlib.sha256((out / rel).read_bytes()).hexdigest() == digest
    again = adverbs.dataset(_spec(tmp_path), out, workers=0)
    assert again.complete and again.skipped == SHARDS - len(first.shard_errors)
    assert _files(out) == _files(reference)


def test_a_killed_run_resumes_where_it_stopped(reference, tmp_path):
    """The process making the dataset dies (SIGKILL) just after its first shard is written; the same command again
    makes only the rest, and the dataset is the one a clean run makes."""
    spec, out = _spec(tmp_path), tmp_path / "ds"
    code = (
        "import os, signal, adverbs\n"
        f"adverbs.dataset({str(spec)!r}, {str(out)!r}, workers=0, on_shard=lambda r: os.kill(os.getpid(), signal.SIGKILL))\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False, timeout=120)
    assert r.returncode == -signal.SIGKILL, r.stderr
    assert [p.parent.name for p in sorted(out.glob("shards/*/done.json"))] == ["000000"]
    assert not (out / "manifest.parquet").exists()
    r = run("dataset", spec, "--out", out, "--workers", "0")
    assert r.returncode == 0, r.stderr
    assert f"1 of {SHARDS} shards done before, skipped" in r.stdout and "8 clips made (1 failed)" in r.stdout
    assert _files(out) == _files(reference)


def test_the_manifest_and_arrays_read_back(reference):
    table = pq.read_table(reference / "manifest.parquet")
    assert table.schema.names == SCHEMA.names and table.num_rows == CLIPS
    assert table["clip"].to_pylist() == list(range(CLIPS))
    ds = adverbs.load_dataset(reference)
    assert len(ds) == CLIPS - 1
    (bad,) = ds.failed
    assert bad["source"] == "cmu-walk-far" and bad["frames"] == 0 and "degenerates" in bad["error"] and "turn" in bad["error"]
    kinds = {r["source"]: r["kind"] for r in ds.rows}
    assert kinds == {"cmu-walk": "verb", "bandai-bow": "verb", "cmu-walk-far": "verb", "cmu": "graph"}
    for i, item in enumerate(ds):
        f, j = item["frames"], 19 if item["source"] != "bandai-bow" else 22
        assert item["rotations"].shape == (f, j, 4) and item["positions"].shape == (f, j, 3)
        assert item["rotations"].dtype == np.float32
        np.testing.assert_allclose(np.linalg.norm(item["rotations"], axis=-1), 1.0, atol=1e-6)
        # The BVH file of the clip is the same motion as its arrays.
        clip = read_bvh(reference / item["bvh"])
        np.testing.assert_allclose(clip.global_positions(), item["positions"], atol=2e-4)
        if item["kind"] == "verb" and item["source"] != "bandai-bow":
            assert item["toe_drift_max_mm"] < 5.0 and item["aloft_max_mm"] < 20.0 and item["never_down"] == ""
            assert set(item["adverbs"]) == {"speed", "turn"}
        if item["kind"] == "graph":
            cues = json.loads(item["script"])
            assert cues and all(c["perform"] in ("walk", "run") for c in cues)
            assert set(item["played"].split(" > ")) <= {"walk", "run"}
            assert math.isclose(item["seconds"], round(item["duration"] * 30) / 30)
        assert i == 0 or ds.rows[i - 1]["clip"] < item["clip"]
    walk = ds.source("cmu-walk")
    assert walk.skeleton.num_joints == 19 and walk.adverb_names == ("speed", "turn")


def test_points_fill_the_range_and_repeat_from_the_seed(tmp_path):
    spec = load_dataset_spec(_spec(tmp_path))
    walk = adverbs.build_from_spec(ROOT / "specs/cmu_walk.toml")
    lo, hi = walk.points.min(axis=0), walk.points.max(axis=0)
    for sampler in ("uniform", "sobol", "lhs"):
        entry = replace(spec.entries[0], sampler=sampler, clips=64)
        names, p = draw_points(spec, 0, entry, walk)
        again = draw_points(spec, 0, entry, walk)[1]
        assert names == ("speed", "turn") and p.shape == (64, 2) and np.array_equal(p, again)
        span = hi - lo
        assert np.all(p >= lo - 0.1 * span) and np.all(p <= hi + 0.1 * span)
        if sampler == "lhs":  # one point in each of the 64 strata of each adverb
            strata = np.floor((p - (lo - 0.1 * span)) / (1.2 * span) * 64).astype(int)
            assert all(sorted(strata[:, a]) == list(range(64)) for a in range(2))
    grid = replace(spec.entries[0], sampler="grid", grid=4, clips=None)
    _, p = draw_points(spec, 0, grid, walk)
    assert p.shape == (16, 2) and len(np.unique(p[:, 0])) == 4


BAD = {
    "a missing verb file": ('spec = "{root}/specs/cmu_walk.toml"', 'spec = "{root}/specs/no_such_verb.toml"', "verbs[1].spec", "no such file"),
    "an unknown sampler": ('sampler = "sobol"', 'sampler = "halton"', "verbs[1].sampler", "unknown sampler 'halton'"),
    "a NaN margin": ("margin = 0.1", "margin = nan", "verbs[1].margin", "finite"),
    "an unknown format": ('formats = ["arrays", "bvh", "glb"]', 'formats = ["arrays", "fbx"]', "formats", "unknown format 'fbx'"),
    "a zero duration": ("duration = [1.0, 2.0]", "duration = 0", "verbs[1].duration", "above 0"),
    "a negative duration": ("duration = [2.0, 3.0]", "duration = [-1.0, 3.0]", "graphs[1].duration", "above 0"),
    "a graph margin past its reach": ('sampler = "lhs"', 'sampler = "lhs"\nmargin = 0.8', "graphs[1].margin", "at most 0.5"),
    "an adverb the verb lacks": ("turn = 0 }}", "tempo = 0 }}", "verbs[3].points[1].tempo", "no adverb 'tempo'"),
}


@pytest.mark.parametrize("case", list(BAD), ids=list(BAD))
def test_a_bad_spec_is_refused_before_any_work(case, tmp_path, monkeypatch):
    old, new, field, reason = BAD[case]
    text = SPEC.replace(old.format(root=ROOT), new.format(root=ROOT), 1)
    assert text != SPEC
    spec = _spec(tmp_path, text)
    monkeypatch.setattr(runner, "_distributed", lambda *a: pytest.fail("a cluster was started"))
    monkeypatch.setattr(runner, "render_shard", lambda *a: pytest.fail("a clip was made"))
    with pytest.raises(DatasetSpecError) as info:
        adverbs.dataset(spec, tmp_path / "ds", workers=2)
    assert info.value.field == field and reason in str(info.value) and str(spec) in str(info.value)
    assert not (tmp_path / "ds").exists()


def test_the_command_refuses_a_bad_spec_in_one_line(tmp_path):
    spec = _spec(tmp_path, SPEC.replace('sampler = "sobol"', 'sampler = "halton"'))
    r = run("dataset", spec, "--out", tmp_path / "ds")
    assert r.returncode == 1 and not (tmp_path / "ds").exists()
    assert r.stderr.strip().splitlines()[-1] == (
        f"adverbs: error: {spec}: field 'verbs[1].sampler': unknown sampler 'halton'; the samplers are grid, uniform, "
        "sobol, lhs, points"
    )


def test_another_spec_is_not_mixed_into_a_dataset(reference, tmp_path):
    import shutil

    shutil.copytree(reference, tmp_path / "ds")
    with pytest.raises(runner.DatasetError, match="holds another dataset"):
        adverbs.dataset(_spec(tmp_path, SPEC.replace("seed = 11", "seed = 12")), tmp_path / "ds", workers=0)


def test_a_clip_is_a_pure_function_of_its_task():
    """The same task twice gives the same motion; past one cycle the verb's own loop (as synth --cycles) or, with
    loop = "kernel", the sampling kernel's faded seams: the same frames, both planted."""
    from adverbs.dataset import ClipTask, clip
    from adverbs.dataset.sources import graph_bytes, graph_from_bytes

    walk = adverbs.build_from_spec(ROOT / "specs/cmu_walk.toml")
    task = ClipTask(0, 0, "verb", (("speed", 1.4), ("turn", 20.0)), 5, 3.0, None, "slope:4")
    a, b = clip(walk, task), clip(walk, task)
    assert np.array_equal(a.motion.rotations, b.motion.rotations) and np.array_equal(a.motion.translations, b.motion.translations)
    fast = clip(walk, replace(task, loop="kernel"))
    assert fast.motion.num_frames == a.motion.num_frames == 91
    assert a.feet.toe_drift.max() < 0.005 and fast.feet.toe_drift.max() < 0.005
    # A graph shipped as bytes plays as the graph it was.
    graph = adverbs.load_graph(ROOT / "graphs/cmu.toml")
    script = json.dumps([{"at": 1.0, "perform": "run", "adverbs": {"turn": 30.0}}])
    task = ClipTask(1, 0, "graph", (("walk_speed", 1.3),), 9, 3.0, 30.0, "flat", script)
    here, there = clip(graph, task), clip(graph_from_bytes(graph_bytes(graph)), task)
    assert np.array_equal(here.motion.rotations, there.motion.rotations) and here.played == there.played == "walk > run"


def test_clips_stepped_together_are_each_the_clip_made_alone():
    """A shard's looped verb clips go through the verb's graph together (more than one batch of them here), their
    feet planted one by one: each the same bits as the clip made alone, on its own floor."""
    from adverbs.dataset import ClipTask, clip
    from adverbs.dataset.clip import MAX_BATCH, clips

    walk = adverbs.build_from_spec(ROOT / "specs/cmu_walk.toml")
    rng = np.random.default_rng(4)
    lo, hi = walk.points.min(axis=0), walk.points.max(axis=0)
    tasks = [
        ClipTask(i, 0, "verb", tuple(zip(walk.adverb_names, map(float, lo + rng.random(2) * (hi - lo)))), i,
                 float(rng.uniform(1.2, 2.5)), None, ("flat", "slope:4", "flat:0.1")[i % 3])
        for i in range(MAX_BATCH + 7)
    ]  # fmt: skip
    together = clips(walk, tasks)
    for task, made in zip(tasks, together):
        alone = clip(walk, task)
        assert np.array_equal(made.motion.rotations, alone.motion.rotations), task
        assert np.array_equal(made.motion.translations, alone.motion.translations), task
        assert np.array_equal(made.feet.toe_drift, alone.feet.toe_drift) and made.warnings == alone.warnings


def test_performances_stepped_together_are_each_the_performance_alone():
    """Graph performances under their scripts go through the graph together: each is the clip made alone (its
    default transitions drawn from its own seed), refused commands and refused starts included."""
    from adverbs.dataset import ClipTask, clip
    from adverbs.dataset.clip import clips

    graph = adverbs.load_graph(ROOT / "graphs/cmu.toml")
    rng = np.random.default_rng(8)
    tasks = []
    for i in range(12):
        cues = [{"at": float(t), "perform": ("walk", "run", "swim")[int(rng.integers(3))], "adverbs": {"turn": float(rng.uniform(-40, 40))}} for t in np.cumsum(rng.uniform(0.5, 1.5, 3))]  # fmt: skip
        start = ("walk", "run", None, "fly")[i % 4]
        tasks.append(ClipTask(i, 0, "graph", (("walk_speed", float(rng.uniform(1.0, 1.6))),), int(rng.integers(1 << 30)), float(rng.uniform(4.6, 5.0)), 30.0, ("flat", "slope:4")[i % 2], json.dumps(cues), start))  # fmt: skip
    for task, made in zip(tasks, clips(graph, tasks)):
        try:
            alone = clip(graph, task)
        except adverbs.AdverbsError as e:
            assert isinstance(made, adverbs.AdverbsError) and str(made) == str(e) and task.start == "fly"
            continue
        assert np.array_equal(made.motion.rotations, alone.motion.rotations), task
        assert np.array_equal(made.motion.translations, alone.motion.translations), task
        assert made.played == alone.played and made.warnings == alone.warnings
        assert any("swim" in w for w in made.warnings) == ("swim" in task.script)


def test_the_command_makes_the_same_dataset_on_its_own_local_cluster(reference, tmp_path):
    """`adverbs dataset SPEC --out DIR --workers 2`: a LocalCluster of its own (127.0.0.1, no dashboard), a line per
    shard on stderr (not a terminal), the summary on stdout, and the files of the dataset made in one process."""
    r = run("dataset", _spec(tmp_path), "--out", tmp_path / "ds", "--workers", "2", timeout=300)
    assert r.returncode == 0, r.stderr
    assert f"{CLIPS} clips in {SHARDS} shards; {CLIPS} clips made (1 failed)" in r.stdout and "on 2 workers" in r.stdout
    assert sum(line.startswith("shard ") for line in r.stderr.splitlines()) == SHARDS
    assert "dashboard" not in r.stderr and "8787" not in r.stderr
    assert _files(tmp_path / "ds") == _files(reference)
