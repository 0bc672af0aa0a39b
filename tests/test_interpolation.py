"""B-splines, time warping and linear + radial interpolation: identities and exactness."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import BSpline

from adverbs import AdverbsError
from adverbs.interp import bspline, timewarp
from adverbs.interp.rbf import AdverbInterpolator, bspline_profile

RNG = np.random.default_rng(3)


# ----- B-splines -----------------------------------------------------------------------------


@pytest.mark.parametrize("n", [4, 7, 16])
def test_basis_matches_scipy_and_sums_to_one(n):
    t = np.linspace(0, 1, 101)
    b = bspline.design_matrix(t, n)
    np.testing.assert_allclose(b.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    h = 1.0 / (n - 3)
    knots = np.arange(-3, n + 1) * h  # uniform knots running past both ends
    for k in range(n):
        ref = BSpline.basis_element(knots[k : k + 5], extrapolate=False)(t)
        np.testing.assert_allclose(b[:, k], np.nan_to_num(ref), rtol=0, atol=1e-12)


def test_fit_reproduces_cubics_exactly_and_uses_four_live_points():
    t = np.sort(RNG.uniform(0, 1, 80))
    cubic = np.stack([1 - 2 * t + 3 * t**2 - t**3, np.sin(0) + 0.5 * t**3], axis=1)
    coef, resid = bspline.fit(t, cubic, 9)
    assert np.abs(resid).max() < 1e-12
    tt = RNG.uniform(0, 1, 50)
    idx, w = bspline.basis(tt, 9)
    assert idx.shape == (50, 4) and np.all(np.diff(idx, axis=1) == 1)
    np.testing.assert_allclose(
        bspline.evaluate(coef, tt), np.stack([1 - 2 * tt + 3 * tt**2 - tt**3, 0.5 * tt**3], 1), rtol=0, atol=1e-12
    )
    v0, s0, v1, s1 = bspline.ends(coef)
    np.testing.assert_allclose(v0, [1, 0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(v1, [1, 0.5], rtol=0, atol=1e-12)
    np.testing.assert_allclose(s0, [-2, 0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(s1, [-2 + 6 - 3, 1.5], rtol=0, atol=1e-12)


def test_too_few_samples_for_numcp():
    with pytest.raises(AdverbsError, match="lower NumCP"):
        bspline.fit(np.linspace(0, 1, 5), np.zeros((5, 1)), 8)
    with pytest.raises(AdverbsError, match="at least 4"):
        bspline.check_num_cp(3)


# ----- time warping ---------------------------------------------------------------------------


def test_time_warp_then_inverse_is_identity():
    k = np.cumsum(RNG.uniform(0.1, 0.7, size=(25, 5)), axis=1)
    k = np.concatenate([np.zeros((25, 1)), k], axis=1)  # (25, 6) increasing from 0
    clock = RNG.uniform(0, 1, (25,)) * k[:, -1]
    t = timewarp.generic_time(clock, k)
    np.testing.assert_allclose(timewarp.clock_time(t, k), clock, rtol=0, atol=1e-12)
    g = RNG.uniform(0, 1, 25)
    np.testing.assert_allclose(timewarp.generic_time(timewarp.clock_time(g, k), k), g, rtol=0, atol=1e-12)
    # Keytime m maps to (m − 1) / (N − 1); the warp is monotone.
    warped = timewarp.generic_time(k, k[:, None, :])
    np.testing.assert_allclose(warped, np.broadcast_to(np.linspace(0, 1, 6), warped.shape), rtol=0, atol=1e-12)
    dense = timewarp.generic_time(np.linspace(0, k[0, -1], 500), k[0])
    assert np.all(np.diff(dense) > 0)


def test_the_time_warps_rate_is_continuous_at_keytimes():
    """The paper's warp is linear between keytimes, so its rate dt/dT steps at each: a curve fitted in generic time
    then steps in velocity there (a bow's hips standing on their feet, 1.42 m/s² in one frame, its capture's 0.58).
    Ours turns its rate near each keytime to a mean of its pieces' rates: continuous at every keytime (and across a
    cycle's seam); a piece much shorter than both its neighbours (a run's frame-long flight) nearly the paper's line,
    each piece's middle half at one rate, as the paper's; every keytime still its generic keytime; one piece still
    the line."""
    h = np.array([0.4, 0.9, 0.034, 0.5, 0.3, 0.8])  # a frame-long piece beside long ones
    k = np.r_[0.0, np.cumsum(h)]
    g = timewarp.examples_spacing(np.stack([k, np.r_[0.0, np.cumsum(h * [1.1, 0.9, 1.5, 0.8, 1.2, 1.0])]]))
    step = 1e-7

    def rate(T):
        return (timewarp.generic_time(T + step, k, g) - timewarp.generic_time(T - step, k, g)) / (2 * step)

    h = np.diff(k)
    pieces = np.diff(g) / h
    d, e = timewarp.slopes(k, g)
    ha, hb, ra, rb = np.r_[h[-1], h], np.r_[h, h[0]], np.r_[pieces[-1], pieces], np.r_[pieces, pieces[0]]
    np.testing.assert_allclose(d, (ra * hb + rb * ha) / (ha + hb), rtol=1e-14)  # the shorter piece's rate weighs more
    np.testing.assert_allclose(rate(k[1:-1]), d[1:-1], rtol=1e-6)  # both sides meet at the keytime's own rate
    np.testing.assert_allclose(rate(np.r_[k[0] - 0.01, k[-1] + 0.01]), [d[0], d[-1]], rtol=1e-6)
    assert d[0] == d[-1]  # a cycle's seam: the last keytime's rate is the first's
    np.testing.assert_allclose(timewarp.generic_time(k, k, g), g, rtol=0, atol=1e-15)
    dense = np.linspace(0.0, k[-1], 40001)
    jumps = np.abs(np.diff(rate(dense)))  # the paper's: |pieces[m] - pieces[m - 1]| in one step, at each keytime
    assert jumps.max() < 2 * pieces.max() * (dense[1] - dense[0]) / e.min()
    flight = np.linspace(k[2] + 1e-6, k[3] - 1e-6, 50)
    np.testing.assert_allclose(rate(flight), pieces[2], rtol=0.05)  # within 5% of the paper's line
    mids = k[:-1] + h * np.linspace(0.3, 0.7, 5)[:, None]  # each piece's middle: one rate, at least 3/4 of its own
    assert np.ptp(rate(mids), axis=0).max() < 1e-6 and np.all(rate(mids) >= 0.75 * pieces)
    line = np.array([0.0, 1.3])
    np.testing.assert_allclose(timewarp.generic_time(dense, line), dense / 1.3, rtol=0, atol=1e-15)
    # continuous in the keytimes too: two steps that pass each other in length (a walk's, equal to a rounding)
    steps = np.array([[0.0, 0.533, 1.066], [0.0, 0.533 + 1e-12, 1.066]])
    warped = timewarp.generic_time(np.linspace(0.0, 1.066, 500), steps[:, None, :], np.array([0.0, 0.3, 1.0]))
    np.testing.assert_allclose(warped[0], warped[1], rtol=0, atol=1e-10)


def test_keytimes_must_increase():
    with pytest.raises(AdverbsError, match="keytime 3 is not after keytime 2"):
        timewarp.check_keytimes([0.0, 0.5, 0.5, 1.0])
    with pytest.raises(AdverbsError, match="finite"):
        timewarp.check_keytimes([0.0, np.nan, 1.0])


# ----- linear + radial ------------------------------------------------------------------------


def _points(e=9, a=3):
    return RNG.uniform(-2, 2, size=(e, a)) * [1.0, 30.0, 0.1][:a]


def test_profile_is_the_cubic_bspline():
    r = np.linspace(0, 3, 301)
    ref = np.where(r < 1, (4 - 6 * r**2 + 3 * r**3) / 6, np.where(r < 2, (2 - r) ** 3 / 6, 0.0))
    np.testing.assert_allclose(bspline_profile(r), ref, rtol=0, atol=1e-15)
    assert (
        bspline_profile(np.array(0.0)) == pytest.approx(2 / 3, rel=0, abs=1e-15)
        and bspline_profile(np.array(2.0)) == 0.0
    )


def test_reproduces_examples_exactly_both_ways():
    pts = _points()
    values = RNG.normal(size=(9, 4, 5))
    ip = AdverbInterpolator(pts)
    coef = ip.fit(values)
    np.testing.assert_allclose(ip.evaluate(pts, coef), values, rtol=0, atol=1e-10)
    np.testing.assert_allclose(np.einsum("pe,e...->p...", ip.weights(pts), values), values, rtol=0, atol=1e-10)
    np.testing.assert_allclose(ip.weights(pts), np.eye(9), rtol=0, atol=1e-10)


def test_cardinal_weights_equal_the_reference_path():
    pts = _points()
    ip = AdverbInterpolator(pts)
    values = RNG.normal(size=(9, 7))
    coef = ip.fit(values)
    p = RNG.uniform(-4, 4, size=(200, 3)) * [1.0, 30.0, 0.1]  # inside and far outside
    fast = ip.weights(p) @ values
    assert np.abs(fast - ip.evaluate(p, coef)).max() <= 1e-10
    np.testing.assert_allclose(ip.weights(p).sum(axis=1), 1.0, rtol=0, atol=1e-12)
    one = np.stack([ip.weights_one(x) for x in p[:20]])
    assert np.abs(one - ip.weights(p[:20])).max() <= 1e-12


def test_linear_fields_are_reproduced_everywhere():
    pts = _points()
    slope, offset = RNG.normal(size=(3, 6)), RNG.normal(size=6)
    ip = AdverbInterpolator(pts)
    p = RNG.uniform(-10, 10, size=(100, 3))
    assert np.abs(ip.weights(p) @ (pts @ slope + offset) - (p @ slope + offset)).max() <= 1e-10


def test_radial_bases_have_compact_support():
    pts = _points(12)
    ip = AdverbInterpolator(pts)
    p = RNG.uniform(-3, 3, size=(2000, 3)) * [1.0, 30.0, 0.1]
    q = (p - ip.centre) / ip.scale
    qi = (pts - ip.centre) / ip.scale
    dist = np.linalg.norm(q[:, None] - qi[None], axis=-1)
    radial = ip.radial(p)
    assert np.all(radial[dist >= 2 * ip.alpha] == 0.0)
    assert np.all(radial[dist < 1.9 * ip.alpha] > 0.0)


def test_moving_a_refinement_far_away_changes_nothing_elsewhere():
    """A refinement example (not in the linear fit) is local: move it far and the rest stays exactly."""
    pts = np.array([[0.0, 0], [1, 0], [0, 1], [1, 1], [6, 6], [7, 6], [6, 7], [7, 7], [6.5, 6.5]])
    values = RNG.normal(size=(9, 3))
    refine = np.zeros(9, dtype=bool)
    refine[8] = True
    before = AdverbInterpolator(pts, linear=~refine)
    moved = pts.copy()
    moved[8] = [40.0, 30.0]
    after = AdverbInterpolator(moved, linear=~refine)
    # Near the left group, whose supports never meet the refinement's old or new place: nothing changes.
    near_left = RNG.uniform(-0.3, 1.3, size=(300, 2))
    assert np.abs(before.weights(near_left) @ values - after.weights(near_left) @ values).max() <= 1e-12
    # Near where it was, the verb changes; at every other example, it still reproduces them.
    assert np.abs(before.weights(pts[8]) @ values - after.weights(pts[8]) @ values).max() > 1e-3
    np.testing.assert_allclose(after.weights(moved) @ values, values, rtol=0, atol=1e-10)


def test_interpolator_errors():
    pts = _points(4)
    with pytest.raises(AdverbsError, match="'b' and 'd' are at the same adverb point"):
        AdverbInterpolator(np.vstack([pts[:3], pts[1:2]]), names=["a", "b", "c", "d"])
    bad = pts.copy()
    bad[2, 1] = np.nan
    with pytest.raises(AdverbsError, match="'example 3' has a non-finite"):
        AdverbInterpolator(bad)
    bad[2, 1], bad[3, 1] = 1e308, -1e308  # finite, but their range overflows: the two would look alike
    with pytest.raises(AdverbsError, match=r"'example 3' has an adverb value beyond ±1e\+12"):
        AdverbInterpolator(bad)
    ip = AdverbInterpolator(pts)
    with pytest.raises(AdverbsError, match="finite"):
        ip.weights(np.array([0.0, np.nan, 0.0]))
    with pytest.raises(AdverbsError, match="finite"):
        ip.weights_one(np.array([0.0, np.inf, 0.0]))
    with pytest.raises(AdverbsError, match=r"\(\.\.\., 3\)"):
        ip.weights(np.zeros(2))
