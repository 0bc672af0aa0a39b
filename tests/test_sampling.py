"""One evaluation path: every way of sampling a verb agrees, on the real verbs, at every boundary time.

One shared test class runs against each evaluation path — one creature at a time (``pose`` with a
kept state), C creatures in one call (``sample``; few and many, which the kernel groups differently),
many queries of one state (what ``synthesize`` runs), the kernel run by the Python interpreter, and
the reference written out with explicit coefficients (eq. 3). All must reproduce the examples, agree
with the reference and with each other at boundary times: 0, around every keytime, at and just past
every cycle end, negative and huge clocks.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import VERB_SPECS

from adverbs import AdverbsError
from adverbs.interp import bspline, timewarp
from adverbs.verb import sampling
from adverbs.verb._sampling_kernel import refresh_batch, sample_batch
from adverbs.verb.synthesis import synthesize_dofs

CYCLIC = ["cmu_walk", "bandai_styled_walk"]


def _single(verb, points, clocks):
    state = verb.state()  # one creature, its state kept across calls (cache hits and misses)
    return np.stack([verb.pose(p, c, state) for p, c in zip(points, clocks)])


def _batched(verb, points, clocks):
    return verb.sample(points, clocks, verb.state(len(points)))[0]


def _queries(verb, points, clocks):
    state = verb.state(len(points))
    state.update(verb, np.asarray(points, dtype=float))
    return sampling.clocks_dofs(verb, state, np.arange(len(points)), clocks)


def _interpreted(verb, points, clocks, monkeypatch):
    monkeypatch.setattr(sampling, "sample_batch", sample_batch.py_func)
    monkeypatch.setattr(sampling, "refresh_batch", refresh_batch.py_func)
    return verb.sample(points, clocks)[0]


def _reference(verb, points, clocks):
    return sampling.sample_reference(verb, points, clocks)


PATHS = {
    "single": _single,
    "batched": _batched,
    "queries": _queries,
    "interpreted": _interpreted,
    "reference": _reference,
}


def _run(path, verb, points, clocks, monkeypatch):
    points = np.asarray(points, dtype=float)
    clocks = np.asarray(clocks, dtype=float)
    if path == "interpreted":
        return _interpreted(verb, points, clocks, monkeypatch)
    return PATHS[path](verb, points, clocks)


def _boundary_clocks(k: np.ndarray, cyclic: bool) -> np.ndarray:
    """Clock times where evaluation changes regime: 0, around each keytime, around cycle ends, negative."""
    end = k[-1]
    out = [0.0, -1e-9, -1.0, -1e6, 1e-12]
    for m in range(len(k)):
        out += [k[m], k[m] - 1e-9, k[m] + 1e-9]
    if cyclic:
        for n in (1, 2, 5):
            out += [n * end, n * end - 1e-9, n * end + 1e-9, n * end * (1 + 1e-6), n * end + 0.5 * k[1]]
    else:
        out += [end + 1e-9, 2 * end, 1e9]
    return np.array(out)


def _huge_clocks(k: np.ndarray) -> np.ndarray:
    """A million cycles on and more: the phase there depends on the last bits of the cycle's duration."""
    return np.array([1e6 * k[-1] + 0.3 * k[-1], 123456789.0, 1e9, 1e15])


def _spread(verb, rng, n):
    """Adverb points at, between and 25% past the examples."""
    lo, hi = verb.points.min(axis=0), verb.points.max(axis=0)
    return rng.uniform(lo - 0.25 * (hi - lo), hi + 0.25 * (hi - lo), size=(n, len(lo)))


@pytest.mark.parametrize("path", list(PATHS))
@pytest.mark.parametrize("name", VERB_SPECS)
class TestEveryPath:
    def test_reproduces_the_examples(self, verbs, name, path, monkeypatch):
        verb, _ = verbs[name]
        rng = np.random.default_rng(1)
        for i in range(len(verb.examples)):
            k = verb.keytimes_table[i]
            clocks = np.concatenate([[0.0, k[-1]], k[1:-1], rng.uniform(0, k[-1], 6)])
            got = _run(path, verb, np.repeat(verb.points[i : i + 1], len(clocks), 0), clocks, monkeypatch)
            want = bspline.evaluate(verb.coefficients[i], timewarp.generic_time(clocks, k, verb.generic_keytimes))
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)

    def test_agrees_with_the_reference_anywhere(self, verbs, name, path, monkeypatch):
        verb, _ = verbs[name]
        rng = np.random.default_rng(2)
        points = _spread(verb, rng, 100)  # more than the kernel groups by segment
        clocks = rng.uniform(-0.2, 5.2, 100) * verb.keytimes(points)[:, -1]
        got = _run(path, verb, points, clocks, monkeypatch)
        np.testing.assert_allclose(got, _reference(verb, points, clocks), rtol=0, atol=1e-10)

    def test_boundary_times(self, verbs, name, path, monkeypatch):
        verb, _ = verbs[name]
        rng = np.random.default_rng(3)
        for p in [verb.points[0], _spread(verb, rng, 1)[0]]:
            clocks = _boundary_clocks(verb.keytimes(p), verb.cyclic)
            points = np.repeat(p[None], len(clocks), 0)
            got = _run(path, verb, points, clocks, monkeypatch)
            assert np.all(np.isfinite(got))
            np.testing.assert_allclose(got, _reference(verb, points, clocks), rtol=0, atol=1e-10)
            # Huge clocks: finite everywhere. The phase after n cycles carries n times the rounding of
            # the cycle's duration, which the reference computes differently (eq. 3 coefficients), so
            # huge times are held to the kernel reading the same keytimes rather than to the reference.
            huge = _huge_clocks(verb.keytimes(p))
            points = np.repeat(p[None], len(huge), 0)
            got = _run(path, verb, points, huge, monkeypatch)
            assert np.all(np.isfinite(got))
            if path != "reference":
                np.testing.assert_allclose(got, _batched(verb, points, huge), rtol=0, atol=1e-10)


@pytest.mark.parametrize("name", VERB_SPECS)
def test_boundary_values_mean_what_they_should(verbs, name):
    """Before the start holds the start; a cycle end joins the next cycle; a one-shot holds its end."""
    verb, _ = verbs[name]
    p = verb.points[1]
    state = verb.state(5)
    state.update(verb, np.repeat(p[None], 5, 0))
    k = state.keytimes[0]  # the kernel's own (NumPy's verb.keytimes may differ in the last bit)
    clocks = [-3.0, 0.0, k[-1], k[-1] + 1e-9, 7.5 * k[-1]]
    at = dict(zip(["neg", "zero", "end", "past", "far"], verb.sample(np.repeat(p[None], 5, 0), clocks, state)[0]))
    np.testing.assert_array_equal(at["neg"], at["zero"])
    cp = verb.control_points(p)
    v0, _, v1, _ = bspline.ends(cp)
    np.testing.assert_allclose(at["zero"], v0, rtol=0, atol=1e-10)
    np.testing.assert_allclose(at["end"], v1, rtol=0, atol=1e-10)
    np.testing.assert_allclose(at["past"], v1, rtol=0, atol=1e-6)  # continuous across the seam
    if not verb.cyclic:
        np.testing.assert_array_equal(at["far"], at["end"])


@pytest.mark.parametrize("name", CYCLIC)
def test_pose_batched_and_synthesize_agree_over_five_cycles(verbs, name):
    verb, _ = verbs[name]
    rng = np.random.default_rng(4)
    for p in [verb.points[0], verb.points[-1], _spread(verb, rng, 1)[0]]:
        dofs, k, fps = synthesize_dofs(verb, p, cycles=5)
        clocks = np.arange(len(dofs)) / fps
        assert clocks[-1] == pytest.approx(5 * k[-1], abs=0.5 / fps)
        state = verb.state()
        single = np.stack([verb.pose(p, c, state) for c in clocks])
        batched, _ = verb.sample(np.repeat(p[None], len(clocks), 0), clocks)
        np.testing.assert_allclose(single, dofs, rtol=0, atol=1e-10)
        np.testing.assert_allclose(batched, dofs, rtol=0, atol=1e-10)
        clip, _ = verb.synthesize(p, cycles=5)
        rot, trans = verb.encoding.decode(dofs, fps)
        np.testing.assert_array_equal(clip.rotations, rot)
        np.testing.assert_array_equal(clip.translations, trans)


def test_two_creatures_alternating_give_what_each_gives_alone(verbs):
    verb, _ = verbs["bandai_styled_walk"]
    a, b = verb.points[0], verb.points[6] + 0.1
    clocks = np.linspace(0, 3 * verb.duration(a), 41)
    alone_a = np.stack([verb.pose(a, c) for c in clocks])  # a fresh state each call
    alone_b = np.stack([verb.pose(b, c) for c in clocks])
    sa, sb = verb.state(), verb.state()
    both = [(verb.pose(a, c, sa), verb.pose(b, c, sb)) for c in clocks]
    np.testing.assert_array_equal(np.stack([x for x, _ in both]), alone_a)
    np.testing.assert_array_equal(np.stack([y for _, y in both]), alone_b)
    # And the same two as one batch of two creatures.
    two, _ = verb.sample(np.stack([a, b]), [clocks[7], clocks[7]])
    np.testing.assert_array_equal(two, np.stack([alone_a[7], alone_b[7]]))


@pytest.mark.parametrize("creatures", [3, 200])
def test_batch_equals_single_for_crowds(verbs, creatures):
    """Few creatures are done one by one in the kernel, many grouped by segment: both equal one at a time."""
    verb, _ = verbs["cmu_walk"]
    rng = np.random.default_rng(creatures)
    points = _spread(verb, rng, creatures)
    state = verb.state(creatures)
    for frame in range(3):
        clocks = rng.uniform(0, 4, creatures)
        if frame == 2:
            points[::2] += 0.05  # half the crowd changes its adverbs: only those rows are recomputed
        crowd, state = verb.sample(points, clocks, state)
        one = np.stack([verb.pose(p, c) for p, c in zip(points, clocks)])
        np.testing.assert_allclose(crowd, one, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(state.cycle, np.maximum(np.ceil(clocks / verb.keytimes(points)[:, -1] - 1e-9) - 1, 0))


def test_compiled_weights_equal_the_interpolator(verbs):
    for name in VERB_SPECS:
        verb, _ = verbs[name]
        points = _spread(verb, np.random.default_rng(5), 50)
        state = verb.state(50)
        state.update(verb, points)
        np.testing.assert_allclose(state.weights, verb.blend(points), rtol=0, atol=1e-12)
        np.testing.assert_allclose(state.keytimes, verb.keytimes(points), rtol=0, atol=1e-12)
        seam = state.weights @ verb.seam_table if verb.cyclic else 0.0  # one-shot verbs never cross a seam
        np.testing.assert_allclose(state.seam, seam + 0 * state.seam, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", CYCLIC)
def test_root_stepped_frame_by_frame_is_the_synthesized_root(verbs, name):
    """Decoding a pose and advancing the root are separate steps; run per frame they give synthesize's clip."""
    verb, _ = verbs[name]
    p = verb.points[3]
    clip, _ = verb.synthesize(p, cycles=3, start=(1.0, -2.0, 0.7))
    state = verb.state(root=(1.0, -2.0, 0.7))
    dt = 1.0 / clip.fps
    for f in range(clip.num_frames):
        dofs, state = verb.sample(p, [f * dt], state)
        rot, trans = verb.encoding.decode_pose(dofs, state.root)
        np.testing.assert_allclose(rot[0], clip.rotations[f], rtol=0, atol=1e-12)
        np.testing.assert_allclose(trans[0], clip.translations[f], rtol=0, atol=1e-9)
        state = sampling.advance(verb, state, dofs, dt)


def test_states_and_tables_guard_themselves(verbs):
    walk, _ = verbs["cmu_walk"]
    reach, _ = verbs["bandai_reach"]
    with pytest.raises(AdverbsError, match="belongs to verb 'cmu-walk'"):
        reach.pose(reach.points[0], 0.1, walk.state())
    with pytest.raises(AdverbsError, match="holds 2 creatures"):
        walk.sample(walk.points[:3], [0.0, 0.1, 0.2], walk.state(2))
    with pytest.raises(AdverbsError, match=r"must be \(C, 2\)"):
        walk.sample(np.zeros((3, 3)), [0.0, 0.1, 0.2])
    with pytest.raises(AdverbsError, match="creatures must be"):
        walk.state(0)
    state = walk.state(2)
    good, _ = walk.sample(walk.points[:2], [0.1, 0.2], state)
    kept = state.weights.copy()
    with pytest.raises(AdverbsError, match="'turn' must be a finite number"):
        walk.sample(np.array([[1.2, np.nan], [1.3, 0.0]]), [0.1, 0.2], state)
    np.testing.assert_array_equal(state.weights, kept)  # a refused command loses nothing
    with pytest.raises(AdverbsError, match="finite"):
        walk.pose(np.array([np.nan, 0.0]), 0.1, walk.state())  # NaN on a fresh state is refused, not cached
    again, _ = walk.sample(walk.points[:2], [0.1, 0.2], state)
    np.testing.assert_array_equal(again, good)
    with pytest.raises(ValueError, match="read-only"):
        walk.coefficients[0, 0, 0] = 1.0
    with pytest.raises(AttributeError):
        walk.points = walk.points * 2


@pytest.mark.parametrize("name", VERB_SPECS)
def test_one_pose_in_one_call_is_the_general_path_bit_for_bit(verbs, name):
    """``pose`` of a verb without a goal chain checks, caches and samples a point in one compiled call
    (``_sampling_kernel.pose_one``); the general path (``SamplingState.update``, then the kernel) gives the same bits,
    and a point it refuses is refused the same way, the state left as it was."""
    verb, _ = verbs[name]
    rng = np.random.default_rng(9)
    points = np.concatenate([_spread(verb, rng, 20), verb.points[:3]])
    clocks = rng.uniform(-0.5, 4 * verb.duration(points[0]), len(points))
    fast, general = verb.state(), verb.state()
    for p, c in zip(points, clocks):
        for again in (False, True):  # a new point, then the same point cached
            one = verb.pose(p, c + again * 0.1, fast)
            ref = sampling._sample_state(verb, p[None], np.array([c + again * 0.1]), general)[0][0]
            np.testing.assert_array_equal(one, ref)
            for field in ("points", "cached", "weights", "keytimes", "seam", "cycle"):
                np.testing.assert_array_equal(getattr(fast, field), getattr(general, field))
    if verb.goal is None:
        kept = fast.weights.copy()
        far = verb.points.mean(axis=0) + 1e9 * np.ptp(verb.points, axis=0)
        with pytest.raises(AdverbsError, match="degenerates"):
            verb.pose(far, 0.1, fast)
        np.testing.assert_array_equal(fast.weights, kept)
