"""The compiled loop behind :func:`adverbs.verb.sampling.sample`: clock → cycle → generic time → DOFs, query by query.

What it does is written out, step by step with NumPy, in :func:`adverbs.verb.sampling.sample_reference`
(and in :mod:`adverbs.interp.timewarp` and :mod:`adverbs.interp.bspline`); a test holds the two equal.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..interp._warp_scalars import warp

GENERIC, CYCLIC, ONE_SHOT = 0, 1, 2  # what the times are: generic times, clock times of a cycle or of a one-shot
CYCLE_EPS = 1e-9  # a time within this fraction of a cycle past its end still belongs to that cycle
GROUPED = 64  # from this many queries on, they are grouped by B-spline segment into matrix products
VELOCITIES = 3  # the first DOF columns are the root's velocities (vx, vz, turn): their seam fade keeps the integral


@njit(cache=True)
def sample_batch(
    segments, weights, keytimes, generic, seam, goal, goal_columns, goal_window, rows, times, mode, window, out, cycles
):  # pragma: no cover
    """Write DOFs ``out (Q, D)`` and cycle indices ``cycles (Q,)`` for ``Q`` queries.

    segments (NumCP, E, D)  control points / 6, by control point (the verb's ``segments``)
    weights  (C, E)         cardinal weights of each creature's adverb point
    keytimes (C, N)         each creature's keytimes (read for clock times only)
    generic  (N,)           where the keytimes sit in generic time (the verb's ``generic_keytimes``)
    seam     (C, D)         each creature's seam jump ``d(1) − d(0)`` (read for cycles only)
    goal     (C, K)         each creature's goal offset on the DOF columns ``goal_columns (K,)`` (K = 0: none)
    goal_window (3,)        generic times the goal's weight rises from, peaks at and falls to (see :mod:`.goal`)
    rows     (Q,) int       the creature of each query
    times    (Q,)           generic times (``mode`` GENERIC) or clock times in seconds
    window   float          fraction of a cycle over which the seam is faded out

    Each query's DOFs are ``Σ_k Σ_e b_k(t) w_e c_{e, seg+k} + fade · seam + reach · goal``: a product of its 4·E
    blend weights with the 4·E rows of control points live at its segment. The root's velocity
    columns fade with ``fade − 3 s (1 − s)`` instead (``s`` the fraction of the window): it starts at 1
    too, so the velocities are continuous at the seam, but integrates to zero over the window, so the
    blend adds no distance and no turn to a cycle (the plain fade added up to 25 deg per cycle). A few queries are done
    one by one; many are grouped by segment so each group is one matrix product (BLAS).
    """
    ncp, ne, nd = segments.shape
    nq = rows.shape[0]
    segs = np.empty(nq, np.int64)
    blend = np.empty((nq, 4))
    fades = np.empty(nq)
    vfades = np.empty(nq)
    reach = np.zeros(nq)
    ng = goal_columns.shape[0]
    for q in range(nq):
        segs[q], fades[q], vfades[q], cycles[q], t = phase(
            keytimes, generic, rows[q], times[q], mode, window, ncp, blend[q]
        )
        if ng > 0:
            reach[q] = goal_weight(goal_window, t)
    nv = min(VELOCITIES, nd)
    if nq < GROUPED:
        for q in range(nq):
            c = rows[q]
            query_into(out[q], segments, weights[c], segs[q], blend[q], seam[c], fades[q], vfades[q], nv, reach[q],
                       goal[c], goal_columns)  # fmt: skip
        return
    flat = np.ascontiguousarray(segments).reshape(ncp * ne, nd)
    order = np.argsort(segs, kind="mergesort")
    start = 0
    while start < nq:
        seg = segs[order[start]]
        stop = start
        while stop < nq and segs[order[stop]] == seg:
            stop += 1
        # Only the examples some creature of the group weighs: a verb that holds DOFs past its hull has 2E weights
        # of which the second E are zero for every point inside it (verb.tables.follows).
        used = np.zeros(ne, dtype=np.bool_)
        for i in range(stop - start):
            c = rows[order[start + i]]
            for e in range(ne):
                if weights[c, e] != 0.0:
                    used[e] = True
        cols = np.flatnonzero(used)
        nu = cols.shape[0]
        mixed = np.empty((stop - start, 4 * nu))
        for i in range(stop - start):
            q = order[start + i]
            c = rows[q]
            for k in range(4):
                for j in range(nu):
                    mixed[i, k * nu + j] = blend[q, k] * weights[c, cols[j]]
        if nu == ne:
            block = np.dot(mixed, flat[seg * ne : (seg + 4) * ne])
        else:
            points = np.empty((4 * nu, nd))
            for k in range(4):
                for j in range(nu):
                    points[k * nu + j] = flat[(seg + k) * ne + cols[j]]
            block = np.dot(mixed, points)
        for i in range(stop - start):
            q = order[start + i]
            c = rows[q]
            _seam_into(out[q], seam[c], fades[q], vfades[q], nv)
            for d in range(nd):
                out[q, d] += block[i, d]
            if reach[q] != 0.0:
                for k in range(ng):
                    out[q, goal_columns[k]] += reach[q] * goal[c, k]
        start = stop


@njit(cache=True, inline="always")
def query_into(out, segments, weights, seg, blend, seam, fade, vfade, nv, reach, goal, goal_columns):  # pragma: no cover
    """One query's DOFs ``out (D,)`` one by one (no BLAS): the seam's part, then ``Σ_e Σ_k b_k w_e c_{e, seg+k}``
    (examples of weight 0 skipped), then the goal's; ``blend (4,)`` and ``seg`` from :func:`phase`."""
    nd = out.shape[0]
    _seam_into(out, seam, fade, vfade, nv)
    for e in range(weights.shape[0]):
        w = weights[e]
        if w == 0.0:
            continue
        a0, a1, a2, a3 = blend[0] * w, blend[1] * w, blend[2] * w, blend[3] * w
        s0, s1, s2, s3 = segments[seg, e], segments[seg + 1, e], segments[seg + 2, e], segments[seg + 3, e]
        for d in range(nd):
            out[d] += a0 * s0[d] + a1 * s1[d] + a2 * s2[d] + a3 * s3[d]
    if reach != 0.0:
        for k in range(goal_columns.shape[0]):
            out[goal_columns[k]] += reach * goal[k]


@njit(cache=True, inline="always")
def _seam_into(row, seam, fade, vfade, nv):  # pragma: no cover
    """``row (D,)`` = the seam's part of one query, ``fade · seam`` (``vfade`` on the first ``nv`` columns), or zeros.

    Past the seam's window both fades are 0 and ``seam`` is not read at all. Written per element as
    ``f * seam[d] if f != 0 else 0``, the compiler may load ``seam`` anyway (a branch-free select): a crowd's rows
    of it, visited in segment order, missed the cache (10,000 creatures of the one-shot Bandai reach, whose seam
    is all zeros: 27 ms a frame, 10 ms now), and generic-time queries pass an empty seam.
    """
    if fade == 0.0 and vfade == 0.0:
        for d in range(row.shape[0]):
            row[d] = 0.0
        return
    for d in range(row.shape[0]):
        row[d] = (vfade if d < nv else fade) * seam[d]


@njit(cache=True, inline="always")
def phase(keytimes, generic, c, clock, mode, window, ncp, blend):  # pragma: no cover
    """B-spline segment, seam fades (pose, velocities), cycle and generic time of one query; its basis weights (× 6)
    into ``blend (4,)``."""
    fade = 0.0
    vfade = 0.0
    cycle = 0
    if mode == GENERIC:
        t = clock
    else:
        nk = keytimes.shape[1]
        end = keytimes[c, nk - 1]
        if mode == CYCLIC:
            cycle = max(int(math.ceil(clock / end - CYCLE_EPS)) - 1, 0)
            local = clock - cycle * end
        else:
            local = clock
        local = min(max(local, 0.0), end)
        if cycle > 0:
            s = min(max(local / (window * end), 0.0), 1.0)
            fade = 1.0 - s * s * (3.0 - 2.0 * s)
            vfade = fade - 3.0 * s * (1.0 - s)
        t = warp(keytimes[c], generic, nk, local)
    u = min(max(t, 0.0), 1.0) * (ncp - 3)
    seg = min(int(math.floor(u)), ncp - 4)
    x = u - seg
    x2 = x * x
    x3 = x2 * x
    y = 1.0 - x
    blend[0] = y * y * y
    blend[1] = 3.0 * x3 - 6.0 * x2 + 4.0
    blend[2] = -3.0 * x3 + 3.0 * x2 + 3.0 * x + 1.0
    blend[3] = x3
    return seg, fade, vfade, cycle, t


@njit(cache=True, inline="always")
def goal_weight(window, t):  # pragma: no cover
    """How much of the goal offset is added at generic time ``t``: :func:`adverbs.verb.goal.weight`, for one time."""
    a, m, b = window[0], window[1], window[2]
    if t < m:
        s = min(max((t - a) / (m - a), 0.0), 1.0)
    elif b <= m:
        s = 1.0
    else:
        s = min(max((b - t) / (b - m), 0.0), 1.0)
    return s * s * (3.0 - 2.0 * s)


HULL_TOL = 1e-9  # ranges of the examples: a point nearer the examples' hull than this is inside it (nothing held)
HULL_STEPS = 200  # Wolfe's steps at most (a point in 3 adverbs takes a handful)


@njit(cache=True, inline="always")
def _weights_at(q, example_q, inv_alpha, radial_from_values, lin_pinv, radial, w):  # pragma: no cover
    """Cardinal weights ``w (E,)`` at a scaled adverb point ``q (A,)``: ``R(q) M⁻¹ (I − A A⁺) + A(q) A⁺``."""
    ne, na = example_q.shape
    for e in range(ne):
        s = 0.0
        for a in range(na):
            diff = example_q[e, a] - q[a]
            s += diff * diff
        r = math.sqrt(s) * inv_alpha[e]
        x = max(2.0 - r, 0.0)
        y = max(1.0 - r, 0.0)
        radial[e] = (x * x * x - 4.0 * (y * y * y)) * (1.0 / 6.0)
    for e in range(ne):
        s = lin_pinv[0, e]
        for a in range(na):
            s += q[a] * lin_pinv[a + 1, e]
        w[e] = s
    for j in range(ne):
        rj = radial[j]
        if rj != 0.0:
            for e in range(ne):
                w[e] += rj * radial_from_values[j, e]


@njit(cache=True)
def _affine_nearest(y, corral, n, mu, m, rhs):  # pragma: no cover
    """Barycentric coordinates ``mu[:n]`` of the point of the affine hull of ``y[corral[:n]]`` nearest the origin
    (``[G 1; 1ᵀ 0] [mu; ν] = [0; 1]``, ``G`` their Gram matrix, by Gaussian elimination with partial pivoting);
    False when the corral is affinely dependent."""
    na = y.shape[1]
    k = n + 1
    for i in range(n):
        for j in range(n):
            s = 0.0
            for a in range(na):
                s += y[corral[i], a] * y[corral[j], a]
            m[i, j] = s
        m[i, n] = 1.0
        m[n, i] = 1.0
        rhs[i] = 0.0
    m[n, n] = 0.0
    rhs[n] = 1.0
    scale = 0.0
    for i in range(n):
        scale = max(scale, m[i, i])
    scale = max(scale, 1.0)
    for col in range(k):
        piv = col
        for i in range(col + 1, k):
            if abs(m[i, col]) > abs(m[piv, col]):
                piv = i
        if abs(m[piv, col]) <= 1e-13 * scale:
            return False
        if piv != col:
            for j in range(k):
                m[col, j], m[piv, j] = m[piv, j], m[col, j]
            rhs[col], rhs[piv] = rhs[piv], rhs[col]
        for i in range(col + 1, k):
            f = m[i, col] / m[col, col]
            if f != 0.0:
                for j in range(col, k):
                    m[i, j] -= f * m[col, j]
                rhs[i] -= f * rhs[col]
    for i in range(k - 1, -1, -1):
        s = rhs[i]
        for j in range(i + 1, k):
            s -= m[i, j] * rhs[j]
        rhs[i] = s / m[i, i]
    for i in range(n):
        mu[i] = rhs[i]
    return True


@njit(cache=True)
def hull_nearest(example_q, q, out):  # pragma: no cover
    """The point ``out (A,)`` of the examples' convex hull (scaled points ``example_q (E, A)``) nearest ``q (A,)``;
    returns its squared distance. Wolfe's minimum-norm-point algorithm on ``y_i = x_i − q`` (1976): a corral of
    at most A + 1 examples, grown by the example farthest along −x, shrunk while the affine minimum leaves it."""
    ne, na = example_q.shape
    y = np.empty((ne, na))
    best, i0, big = np.inf, 0, 0.0  # the nearest example, and the farthest's squared distance (a scale)
    for e in range(ne):
        s = 0.0
        for a in range(na):
            y[e, a] = example_q[e, a] - q[a]
            s += y[e, a] * y[e, a]
        if s < best:
            best, i0 = s, e
        big = max(big, s)
    cap = na + 1
    corral = np.empty(cap, np.int64)
    lam = np.empty(cap)
    mu = np.empty(cap)
    m = np.empty((cap + 1, cap + 1))
    rhs = np.empty(cap + 1)
    x = np.empty(na)
    corral[0], lam[0], n = i0, 1.0, 1
    for a in range(na):
        x[a] = y[i0, a]
    for _ in range(HULL_STEPS):
        xx = 0.0
        for a in range(na):
            xx += x[a] * x[a]
        if xx == 0.0:
            break
        j, low = -1, np.inf
        for e in range(ne):
            s = 0.0
            for a in range(na):
                s += x[a] * y[e, a]
            if s < low:
                low, j = s, e
        if xx - low <= 1e-12 * big or n == cap:
            break
        known = False
        for i in range(n):
            known = known or corral[i] == j
        if known:
            break
        corral[n], lam[n] = j, 0.0
        n += 1
        for _minor in range(cap + 1):
            if not _affine_nearest(y, corral, n, mu, m, rhs):
                n -= 1  # the newcomer is affinely dependent: drop it and stop here
                break
            inside = True
            for i in range(n):
                inside = inside and mu[i] > 0.0
            if inside:
                for i in range(n):
                    lam[i] = mu[i]
                break
            theta = 1.0
            for i in range(n):
                if mu[i] <= 0.0 and lam[i] - mu[i] > 0.0:
                    theta = min(theta, lam[i] / (lam[i] - mu[i]))
            k = 0
            for i in range(n):
                v = (1.0 - theta) * lam[i] + theta * mu[i]
                if v > 1e-15:
                    corral[k], lam[k] = corral[i], v
                    k += 1
            if k == 0:
                corral[0], lam[0], k = corral[0], 1.0, 1
            n = k
        total = 0.0
        for i in range(n):
            total += lam[i]
        for a in range(na):
            s = 0.0
            for i in range(n):
                s += lam[i] * y[corral[i], a]
            x[a] = s / total
    d = 0.0
    for a in range(na):
        out[a] = q[a] + x[a]
        d += x[a] * x[a]
    return d


@njit(cache=True)
def refresh_batch(
    points, rows, centre, inv_scale, example_q, inv_alpha, radial_from_values, lin_pinv, log_intervals,
    interval_bounds, seam_table, weights, keytimes, seam,
):  # pragma: no cover  # fmt: skip
    """Cardinal weights, keytimes and seam jump of the creatures ``rows (R,)`` at adverb points ``points (C, A)``.

    ``w(p) = R(p) M⁻¹ (I − A A⁺) + A(p) A⁺`` (see :mod:`adverbs.interp.rbf`), the keytimes from the
    log intervals ``K_{m+1} − K_m = exp(w · log ΔK)`` (each log interval clipped to ``interval_bounds (2, N-1)``)
    and the seam ``w · (d(1) − d(0))``; written into
    ``weights (C, E)``, ``keytimes (C, N)`` and ``seam (C, D)`` at those rows.

    A verb that holds DOFs past its examples (``Verb.follows``) has ``weights (C, 2E)``: after ``w(p)``, the held
    part ``w(h) − w(p)``, ``h`` the point of the examples' hull nearest ``p`` (zeros inside the hull); its
    ``seam_table`` has 2E rows to match (the second E scaled by how much each DOF is held, as its ``segments``).
    """
    ne, na = example_q.shape
    nw = weights.shape[1]
    nk = log_intervals.shape[1] + 1
    nd = seam_table.shape[1]
    q = np.empty(na)
    h = np.empty(na)
    radial = np.empty(ne)
    held = np.empty(ne)
    for i in range(rows.shape[0]):
        c = rows[i]
        for a in range(na):
            q[a] = (points[c, a] - centre[a]) * inv_scale[a]
        w = weights[c]
        _weights_at(q, example_q, inv_alpha, radial_from_values, lin_pinv, radial, w)
        if nw > ne:
            for e in range(ne, nw):
                w[e] = 0.0
            if hull_nearest(example_q, q, h) > HULL_TOL * HULL_TOL:
                _weights_at(h, example_q, inv_alpha, radial_from_values, lin_pinv, radial, held)
                for e in range(ne):
                    w[ne + e] = held[e] - w[e]
        keytimes[c, 0] = 0.0
        for m in range(nk - 1):
            s = 0.0
            for e in range(ne):
                s += w[e] * log_intervals[e, m]
            s = min(max(s, interval_bounds[0, m]), interval_bounds[1, m])
            keytimes[c, m + 1] = keytimes[c, m] + math.exp(s)
        for d in range(nd):
            seam[c, d] = 0.0
        for e in range(nw):
            we = w[e]
            if we != 0.0:
                for d in range(nd):
                    seam[c, d] += we * seam_table[e, d]


@njit(cache=True)
def pose_one(
    point, centre, inv_scale, example_q, inv_alpha, radial_from_values, lin_pinv, log_intervals, interval_bounds,
    seam_table, segments, generic, clock, mode, window, max_gain, shortest, longest, points, cached, weights, keytimes,
    seam, cycles, out,
):  # pragma: no cover  # fmt: skip
    """One creature's pose at adverb ``point (A,)`` and ``clock`` into ``out (D,)``, its state's row 0 (``points``,
    ``cached``, ``weights``, ``keytimes``, ``seam``, ``cycles``) brought up to date first if the point is new: what
    ``SamplingState.update`` then :func:`sample_batch` do for one query, in one call.

    Returns 0, or why the point is refused, changing nothing: 1 not finite, 2 its weights blend the examples more than
    ``max_gain`` times over, 3 its motion lasts outside ``shortest`` .. ``longest`` seconds.
    """
    na = point.shape[0]
    for a in range(na):
        if not math.isfinite(point[a]):
            return 1
    same = cached[0]
    for a in range(na):
        same = same and point[a] == points[0, a]
    if not same:
        p = point.reshape((1, na))
        rows = np.zeros(1, np.int64)
        w, k, s = np.empty((1, weights.shape[1])), np.empty((1, keytimes.shape[1])), np.empty((1, seam.shape[1]))
        refresh_batch(p, rows, centre, inv_scale, example_q, inv_alpha, radial_from_values, lin_pinv, log_intervals,
                      interval_bounds, seam_table, w, k, s)  # fmt: skip
        gain = 0.0
        for e in range(w.shape[1]):
            gain += abs(w[0, e])
        if not gain <= max_gain:
            return 2
        length = k[0, k.shape[1] - 1]
        if not (shortest <= length <= longest):
            return 3
        points[0, :] = point
        weights[0, :] = w[0]
        keytimes[0, :] = k[0]
        seam[0, :] = s[0]
        cached[0] = True
    ncp, _, nd = segments.shape
    blend = np.empty(4)
    seg, fade, vfade, cycles[0], _ = phase(keytimes, generic, 0, clock, mode, window, ncp, blend)
    no_goal = np.zeros(0)
    query_into(out, segments, weights[0], seg, blend, seam[0], fade, vfade, min(VELOCITIES, nd), 0.0, no_goal,
               np.zeros(0, np.int64))  # fmt: skip
    return 0
