"""Every kind of file the project writes is written whole or not at all: a write that fails part way (a file-size
limit, as a full disk would) leaves the previous file as it was, no part-written file beside it, and an error that
names the file. Each writer runs in a child process under ``RLIMIT_FSIZE``."""

from __future__ import annotations

import resource
import subprocess
import warnings
from pathlib import Path

import pytest
from conftest import CMU
from test_cli import run

from adverbs.errors import AdverbsWarning

ROOT = Path(__file__).resolve().parent.parent
LIMIT = 6_000  # bytes: below every output here


@pytest.fixture(scope="module")
def walk(tmp_path_factory):
    from adverbs.verb.fit import build_from_spec
    from adverbs.verb.store import save_verb

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        verb = build_from_spec(ROOT / "specs" / "cmu_walk.toml")
    path = tmp_path_factory.mktemp("verb") / "walk.verb"
    save_verb(verb, path)
    return str(path)


def _adverbs(*args: str, limit: int | None = None) -> subprocess.CompletedProcess:
    return run(*args, limits={resource.RLIMIT_FSIZE: limit} if limit else None, timeout=300)


WRITERS = {
    "synth .bvh": lambda verb, out: ("synth", verb, "--cycles", "2", "-o", out("x.bvh")),
    "synth .glb": lambda verb, out: ("synth", verb, "--cycles", "2", "-o", out("x.glb")),
    "evaluate --png": lambda verb, out: ("evaluate", verb, "--png", out("x.png")),
    "figure": lambda verb, out: ("figure", verb, "--axes", "speed", "turn", "--kind", "space", "-o", out("x.png")),
    "render .png": lambda verb, out: ("render", str(CMU / "16_15_walk.bvh"), "--panels", "2", "-o", out("x.png")),
    "render .gif": lambda verb, out: ("render", str(CMU / "16_15_walk.bvh"), "--fps", "5", "-o", out("x.gif")),
    "convert --portable": lambda verb, out: ("convert", str(CMU / "16_15_walk.bvh"), out("x.bvh"), "--portable"),
}


@pytest.mark.parametrize("kind", list(WRITERS))
def test_a_failed_write_leaves_the_old_file_whole_and_names_it(walk, kind, tmp_path):
    verb = walk
    written: list[Path] = []

    def out(name: str) -> str:
        written.append(tmp_path / name)
        return str(tmp_path / name)

    args = WRITERS[kind](verb, out)
    good = _adverbs(*args)
    assert good.returncode == 0, good.stderr
    target = written[-1]
    before = target.read_bytes()
    assert len(before) > LIMIT
    failed = _adverbs(*args, limit=LIMIT)
    assert failed.returncode == 1, failed.stderr
    assert f"{target}: cannot write" in failed.stderr and "Traceback" not in failed.stderr, failed.stderr
    assert target.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == [target.name]  # nothing part-written left beside it


def test_a_failed_run_keeps_its_recordings_and_log(tmp_path):
    script = tmp_path / "s.toml"
    script.write_text('seconds = 2\n[[creatures]]\nname = "a"\ngraph = "cmu"\n')
    out = tmp_path / "out"
    args = ("run", str(ROOT / "graphs" / "cmu.toml"), "--script", str(script), "--out", str(out))
    good = _adverbs(*args)
    assert good.returncode == 0, good.stderr
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    assert set(before) == {"a.bvh", "events.json"}
    failed = _adverbs(*args, limit=LIMIT)
    assert failed.returncode == 1 and "cannot write" in failed.stderr and "Traceback" not in failed.stderr, failed.stderr
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


def test_a_file_whose_root_is_absurdly_far_is_refused_by_the_writers_and_pictures(tmp_path):
    """One root position of 1e300 (finite: every reader takes it) overflowed glTF's 32-bit floats into a file
    read back as infinite, and made ``render`` build a floor grid it could not hold (a traceback)."""
    lines = (CMU / "16_15_walk.bvh").read_text().splitlines()
    motion = lines.index("MOTION")
    values = lines[motion + 3].split()
    values[0] = "1e300"
    lines[motion + 3] = " ".join(values)
    far = tmp_path / "far.bvh"
    far.write_text("\n".join(lines) + "\n")
    out = _adverbs("convert", far, tmp_path / "far.glb")
    assert out.returncode != 0 and "Traceback" not in out.stderr, out.stderr
    assert "32-bit floats" in out.stderr and not (tmp_path / "far.glb").exists()
    out = _adverbs("render", far, "--panels", "2", "-o", tmp_path / "far.png")
    assert out.returncode != 0 and "Traceback" not in out.stderr, out.stderr
    assert "m from the origin" in out.stderr and not (tmp_path / "far.png").exists()
