"""`adverbs synth --method`: the same adverbs through other interpolators, to compare them."""

from __future__ import annotations

import numpy as np
from conftest import SPECS
from test_cli import run

from adverbs import read_bvh
from adverbs.apps.evaluate import METHODS, predict


def test_every_method_synthesizes_and_agrees_at_an_example(tmp_path, verbs):
    verb_path = tmp_path / "walk.verb"
    assert run("build", SPECS / "cmu_walk.toml", "-o", verb_path).returncode == 0
    verb, _ = verbs["cmu_walk"]
    at = verb.points[2]
    between = (verb.points[0] + verb.points[2]) / 2
    clips = {}
    for method in METHODS:
        for name, p in (("at", at), ("between", between)):
            out = tmp_path / f"{method}_{name}.bvh"
            args = ["--adverb", f"speed={float(p[0])!r}", "--adverb", f"turn={float(p[1])!r}", "--no-ik"]
            r = run("synth", verb_path, *args, "--method", method, "-o", out)
            assert r.returncode == 0, r.stderr
            assert method == "ours" or f"by {method}" in r.stdout
            clips[method, name] = read_bvh(out).global_positions()
    # Every method but the least-squares plane interpolates: at an example they all give the example.
    for method in ("nearest", "idw", "scipy-rbf"):
        assert clips[method, "at"].shape == clips["ours", "at"].shape
        np.testing.assert_allclose(clips[method, "at"], clips["ours", "at"], rtol=0, atol=1e-5)
    # Between examples they differ: the comparison is real.
    for method in ("linear", "nearest", "idw"):
        a, b = clips[method, "between"], clips["ours", "between"]
        n = min(len(a), len(b))
        assert np.abs(a[:n] - b[:n]).max() > 1e-3, method


def test_predict_by_ours_is_the_verb(verbs):
    verb, _ = verbs["bandai_styled_walk"]
    p = verb.points.mean(axis=0)
    cp, k = predict("ours", verb, p)
    np.testing.assert_allclose(cp, verb.control_points(p), rtol=0, atol=1e-9)
    np.testing.assert_allclose(k, verb.keytimes(p), rtol=0, atol=1e-12)


def test_unknown_method_is_a_usage_error(tmp_path):
    r = run("synth", tmp_path / "none.verb", "--method", "magic", "-o", tmp_path / "x.bvh")
    assert r.returncode == 2 and "invalid choice: 'magic'" in r.stderr
