"""The compiled solve behind :func:`adverbs.verb.goal.solve`: the goal chain's offset, adverb point by adverb point.

What it computes is written out in NumPy in :mod:`adverbs.verb.goal` (``_Model`` and ``_solve``), the reference
``tests/test_goal.py`` holds it to. The same mathematics and the same Levenberg–Marquardt steps, with less arithmetic:

* the body root's path to the keytime reads only the root's three velocity columns: each point's control points of
  those are blended once (``Σ_e w_e c_e``, only up to the keytime's), and each of the
  :data:`~adverbs.verb.goal.STEPS` samples of the path is then four products, where the reference samples every DOF
  of the pose at every step;
* a keytime falls at the same generic time at every point, so the pose there (and at time 0) is the blend of the
  examples' own, read once per verb (:func:`tables`) in the columns the goal joint's position reads (``root.y`` and
  the rotations and translations of its ancestors; at time 0 the body root's);
* forward kinematics runs down the goal joint's ancestors alone, and only from the first chain joint on: what is
  above it does not move with the offset and is composed once per point; a trial step's forward kinematics, taken,
  is the next step's, and a rejected step's Jacobian is kept for the next;
* the Jacobian's rotations and the right Jacobian reuse what forward kinematics computed (the joint's rotation, the
  half angle's sine and cosine);
* the ``K × K`` system ``(JᵀJ + λ I) step = g`` is solved through the ``M × M`` one ``(J Jᵀ + λ I) z = J g``
  (``step = (g − Jᵀ z) / λ``; ``M ≤ 3`` goal axes, ``K = 15`` DOFs for the reach's chain), by a Cholesky
  factorization written out.

Decoding and forward kinematics are :mod:`adverbs.motion._pose_kernel`'s and :mod:`adverbs.kinematics._fk_kernel`'s
arithmetic in the same order; the blends, the right Jacobian's ``1 − cos θ`` and the solve differ from the
reference by rounding.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..motion._pose_kernel import _exp, _mul, _rotate, _rotate_about_y
from ._sampling_kernel import ONE_SHOT, phase


@njit(cache=True)
def tables(segments, keytimes, generic, keytime, grid, key_cols, start_cols):  # pragma: no cover
    """What :func:`solve_rows` reads of a verb's control points ``segments (NumCP, E, D)``, for any adverb point: each
    example's DOF columns ``key_cols`` at the goal's keytime ``(E, C)`` and ``start_cols`` at time 0 ``(E, C0)``, and
    the root's velocity columns of the control points up to the keytime's ``(NumCP', E, 3)``.

    A keytime's clock time is that keytime's generic time at every adverb point (:func:`._sampling_kernel.phase` reads
    it as ``G_m + (G_{m+1} − G_m) · 0``, or ``· 1`` at a one-shot verb's last), so its B-spline segment and basis are
    the verb's; ``keytimes (1, N)`` is any point's (the first example's).
    """
    ncp, ne, nd = segments.shape
    blend = np.empty(4)
    key = np.empty((ne, key_cols.shape[0]))
    start = np.empty((ne, start_cols.shape[0]))
    seg = 0
    for table, cols, clock in ((key, key_cols, keytimes[0, keytime] * grid[grid.shape[0] - 1]), (start, start_cols, 0.0)):
        s, _, _, _, _ = phase(keytimes, generic, 0, clock, ONE_SHOT, 0.0, ncp, blend)
        seg = max(seg, s)
        for e in range(ne):
            for j in range(cols.shape[0]):
                c = cols[j]
                table[e, j] = (
                    blend[0] * segments[s, e, c] + blend[1] * segments[s + 1, e, c] + blend[2] * segments[s + 2, e, c]
                    + blend[3] * segments[s + 3, e, c]
                )  # fmt: skip
    velocities = np.ascontiguousarray(segments[: seg + 4, :, :3])
    return velocities, key, start


@njit(cache=True, nogil=True)
def solve_rows(
    lo, hi, velocities, key_pose, start_pose, key_cols, start_cols, ncp, nd, weights, keytimes, generic, grid, keytime,
    points, misses, path_parent, rot_col, trans_col, reference, base, chain, body, parent_inv, parent_pos, has_parent,
    lateral, axes, adverbs, mu, lam0, iterations, tolerance, settled, longest, bound, out, steps_taken,
):  # pragma: no cover  # fmt: skip
    """Offsets ``out[i] (K,)`` on the goal chain of the rows ``lo ≤ i < hi``, and how many steps each took
    (``steps_taken[i]``), by Levenberg–Marquardt from zero; zero for a row whose keytimes or weights are not finite,
    whose keytimes do not increase or whose motion lasts past ``longest`` seconds (``goal.solve``'s rules).

    velocities, key_pose, start_pose, key_cols, start_cols   the verb's :func:`tables` and the columns they hold
    ncp, nd                 the verb's control points and DOFs
    weights (R, E), keytimes (R, N)   the rows' blend weights and keytimes;  generic (N,)  the generic keytimes
    grid (S + 1,)           the root integration's steps in [0, 1];  keytime  the goal's keytime
    points (R, A), misses (E, M)   the rows' adverb points and the examples' own misses (``goal.misses``): the aim is
                            ``points[adverbs] + w · misses``
    path_*                  the goal joint's ancestors, root first (P,): parent within the path (−1: none), first
                            rotation and translation DOF columns (−1: none), reference rotation (P, 4), base
                            translation (P, 3), block of the offset (chain index, −1: not in the chain)
    body                    the body root's place in the path; ``parent_inv``, ``parent_pos``, ``has_parent``: the
                            fixed frame it is decoded below (the encoding's ``above_body``); ``lateral (3,)`` its hips' axis
    axes (M,), adverbs (M,) the measured coordinates (0-2) and the adverbs asking for them
    mu, lam0, iterations, tolerance, settled, longest, bound   the solve's constants (see :mod:`adverbs.verb.goal`)
    """
    nv, ne, _ = velocities.shape
    p_count = path_parent.shape[0]
    m_count = axes.shape[0]
    k_count = out.shape[1]
    n_steps = grid.shape[0] - 1
    mu2 = mu * mu
    blend = np.empty(4)
    vel = np.empty((nv, 3))  # each control point's root velocities, blended
    pose = np.zeros(nd)
    lrot = np.empty((p_count, 4))  # local rotations and translations along the path
    ltrans = np.empty((p_count, 3))
    grot = np.empty((p_count, 4))  # global ones
    gpos = np.empty((p_count, 3))
    trig = np.empty((p_count, 3))  # each chain joint's angle and half angle's sine and cosine
    lrot_trial = np.empty((p_count, 4))  # the same at a trial step's offset (taken: the two swap)
    trig_trial = np.empty((p_count, 3))
    grot_trial = np.empty((p_count, 4))
    gpos_trial = np.empty((p_count, 3))
    first = p_count - 1  # the first chain joint's place in the path
    for j in range(p_count):
        if chain[j] >= 0:
            first = min(first, j)
    delta = np.empty(k_count)
    trial = np.empty(k_count)
    step = np.empty(k_count)
    res = np.empty(m_count)
    trial_res = np.empty(m_count)
    at = np.empty(m_count)
    jac = np.zeros((m_count, k_count))  # a block of the goal joint itself (in a chain) turns it in place: zero
    rhs = np.empty(k_count)
    jjt = np.empty((m_count, m_count))
    small = np.empty((m_count, m_count))
    jg = np.empty(m_count)
    dual_z = np.empty(m_count)
    frame = np.empty(7)  # to_local (4) and origin (3)
    target = np.empty(m_count)
    nk = keytimes.shape[1]
    for i in range(lo, hi):
        w = weights[i]
        kt = keytimes[i, keytime]
        steps_taken[i] = 0
        out[i, :] = 0.0
        sane = keytimes[i, nk - 1] <= longest
        for m in range(nk):
            sane = sane and math.isfinite(keytimes[i, m]) and (m == 0 or keytimes[i, m] - keytimes[i, m - 1] > 0.0)
        for e in range(ne):
            sane = sane and math.isfinite(w[e])
        if not sane:  # a motion degenerated so far that synthesis refuses it: no offset
            continue
        for m in range(m_count):
            s = 0.0
            for e in range(ne):
                s += w[e] * misses[e, m]
            target[m] = points[i, adverbs[m]] + s
        # --- the body root at the keytime: its velocities integrated (DofEncoding.root_path at STEPS / kt fps) ---
        for c in range(nv):
            vx = vz = turn = 0.0
            for e in range(ne):
                we = w[e]
                if we != 0.0:
                    vx += we * velocities[c, e, 0]
                    vz += we * velocities[c, e, 1]
                    turn += we * velocities[c, e, 2]
            vel[c, 0], vel[c, 1], vel[c, 2] = vx, vz, turn
        dt = 1.0 / (n_steps / kt)
        heading = 0.0
        cum_turn = 0.0
        x = 0.0
        z = 0.0
        for s in range(n_steps):
            seg, _, _, _, _ = phase(keytimes, generic, i, kt * grid[s], ONE_SHOT, 0.0, ncp, blend)
            b0, b1, b2, b3 = blend[0], blend[1], blend[2], blend[3]
            vx = b0 * vel[seg, 0] + b1 * vel[seg + 1, 0] + b2 * vel[seg + 2, 0] + b3 * vel[seg + 3, 0]
            vz = b0 * vel[seg, 1] + b1 * vel[seg + 1, 1] + b2 * vel[seg + 2, 1] + b3 * vel[seg + 3, 1]
            turn = b0 * vel[seg, 2] + b1 * vel[seg + 1, 2] + b2 * vel[seg + 2, 2] + b3 * vel[seg + 3, 2]
            cum_turn += turn * dt
            h1 = cum_turn
            sx, _, sz = _rotate_about_y(0.5 * (h1 + heading), vx, 0.0, vz)
            x += sx * dt
            z += sz * dt
            heading = h1
        # --- the character's frame at the start: the body root's heading and ground point in the pose at time 0 ---
        _blend_columns(pose, w, start_pose, start_cols)
        _decode_path(pose, 0.0, 0.0, 0.0, body + 1, path_parent, rot_col, trans_col, reference, base, body, parent_inv,
                     parent_pos, has_parent, lrot, ltrans)  # fmt: skip
        _fk(path_parent, lrot, ltrans, 0, body + 1, grot, gpos)
        lx, _, lz = _rotate(grot[body, 0], grot[body, 1], grot[body, 2], grot[body, 3], lateral[0], lateral[1], lateral[2])
        half = 0.5 * -math.atan2(-lz, lx)
        frame[0], frame[1], frame[2], frame[3] = 0.0, math.sin(half), 0.0, math.cos(half)
        frame[4], frame[5], frame[6] = gpos[body, 0] * 1.0, gpos[body, 1] * 0.0, gpos[body, 2] * 1.0
        # --- the pose at the keytime, in the columns the path reads; the path above the first chain joint, once ---
        _blend_columns(pose, w, key_pose, key_cols)
        _decode_path(pose, x, z, heading, p_count, path_parent, rot_col, trans_col, reference, base, body, parent_inv,
                     parent_pos, has_parent, lrot, ltrans)  # fmt: skip
        _fk(path_parent, lrot, ltrans, 0, first, grot, gpos)
        lrot_trial[:] = lrot
        grot_trial[:] = grot
        gpos_trial[:] = gpos
        # --- Levenberg–Marquardt (goal._solve, written out) ---
        for k in range(k_count):
            delta[k] = 0.0
        _reached(pose, delta, first, path_parent, rot_col, reference, chain, lrot, ltrans, grot, gpos, trig, frame, axes,
                 at)  # fmt: skip
        left, cost = _cost(target, at, res, delta, mu2)
        active = math.sqrt(left) > tolerance
        lam = lam0
        taken = 0
        moved = True
        while active and taken < iterations:
            taken += 1
            if moved:  # a new offset: its Jacobian (FK at delta: the last trial taken); else the last one's still holds
                _jacobian(pose, delta, first, rot_col, chain, grot, gpos, trig, frame, axes, jac)
                for r in range(k_count):
                    s = 0.0
                    for m in range(m_count):
                        s += jac[m, r] * res[m]
                    rhs[r] = s - mu2 * delta[r]
                for r in range(m_count):
                    for c in range(r + 1):
                        s = 0.0
                        for k in range(k_count):
                            s += jac[r, k] * jac[c, k]
                        jjt[r, c] = s
                    s = 0.0
                    for k in range(k_count):
                        s += jac[r, k] * rhs[k]
                    jg[r] = s
            # (JᵀJ + λ I)⁻¹ g = (g − Jᵀ (J Jᵀ + λ I)⁻¹ J g) / λ: an M × M system where the reference solves K × K
            damp = mu2 + lam
            for r in range(m_count):
                for c in range(r + 1):
                    small[r, c] = jjt[r, c]
                small[r, r] += damp
            _cholesky_solve(small, jg, dual_z)
            for k in range(k_count):
                s = rhs[k]
                for m in range(m_count):
                    s -= jac[m, k] * dual_z[m]
                step[k] = s / damp
            for k in range(k_count):
                trial[k] = delta[k] + step[k]
            for b in range(k_count // 3):  # each joint's offset no longer than bound (goal._bounded)
                x, y, z = trial[3 * b], trial[3 * b + 1], trial[3 * b + 2]
                size = math.sqrt(x * x + y * y + z * z)
                if size > bound:
                    for a in range(3):
                        trial[3 * b + a] = trial[3 * b + a] * (bound / size)
            _reached(pose, trial, first, path_parent, rot_col, reference, chain, lrot_trial, ltrans, grot_trial,
                     gpos_trial, trig_trial, frame, axes, at)  # fmt: skip
            trial_left, trial_cost = _cost(target, at, trial_res, trial, mu2)
            better = trial_cost < cost
            done = better and cost - trial_cost <= settled * cost
            moved = better
            if better:
                lrot, lrot_trial = lrot_trial, lrot
                trig, trig_trial = trig_trial, trig
                grot, grot_trial = grot_trial, grot
                gpos, gpos_trial = gpos_trial, gpos
                for k in range(k_count):
                    delta[k] = trial[k]
                for m in range(m_count):
                    res[m] = trial_res[m]
                cost = trial_cost
                left = trial_left
                lam = max(lam / 3.0, 1e-9)
            else:
                lam *= 4.0
            size = 0.0
            for k in range(k_count):
                size += step[k] * step[k]
            active = math.sqrt(left) > tolerance and not math.sqrt(size) < 1e-12 and not done and lam < 1e8
        finite = True
        for k in range(k_count):
            finite = finite and math.isfinite(delta[k])
        if finite:
            for k in range(k_count):
                out[i, k] = delta[k]
        steps_taken[i] = taken


@njit(cache=True, inline="always")
def _cost(target, at, res, delta, mu2):  # pragma: no cover
    """The residual ``res = target − at`` (written) and the solve's ``|res|²`` and cost ``|res|² + μ² |delta|²``."""
    left = 0.0
    for m in range(res.shape[0]):
        res[m] = target[m] - at[m]
        left += res[m] * res[m]
    norm = 0.0
    for k in range(delta.shape[0]):
        norm += delta[k] * delta[k]
    return left, left + mu2 * norm


@njit(cache=True, inline="always")
def _blend_columns(pose, w, table, cols):  # pragma: no cover
    """``pose[cols[j]] = Σ_e w_e table[e, j]``: a pose's columns from the examples' (one of :func:`tables`)."""
    for j in range(cols.shape[0]):
        pose[cols[j]] = 0.0
    for e in range(w.shape[0]):
        we = w[e]
        if we == 0.0:
            continue
        for j in range(cols.shape[0]):
            pose[cols[j]] += we * table[e, j]


@njit(cache=True)
def _decode_path(
    pose, x, z, heading, count, parent, rot_col, trans_col, reference, base, body, parent_inv, parent_pos, has_parent,
    lrot, ltrans,
):  # pragma: no cover  # fmt: skip
    """Local rotations and translations of the first ``count`` path joints of ``pose`` with the body root at ``(x, z,
    heading)``: ``_pose_kernel.decode_row`` for those joints."""
    for j in range(count):
        c = rot_col[j]
        if c >= 0:
            ex, ey, ez, ew = _exp(pose[c], pose[c + 1], pose[c + 2])
            lrot[j, 0], lrot[j, 1], lrot[j, 2], lrot[j, 3] = _mul(
                reference[j, 0], reference[j, 1], reference[j, 2], reference[j, 3], ex, ey, ez, ew
            )
        else:
            lrot[j, 0], lrot[j, 1], lrot[j, 2], lrot[j, 3] = 0.0, 0.0, 0.0, 1.0
        t = trans_col[j]
        for a in range(3):
            if t >= 0:
                ltrans[j, a] = base[j, a] + pose[t + a]
            else:
                ltrans[j, a] = base[j, a]
    if body < count:
        half = 0.5 * heading
        gx, gy, gz, gw = _mul(0.0, math.sin(half), 0.0, math.cos(half), lrot[body, 0], lrot[body, 1], lrot[body, 2],
                              lrot[body, 3])  # fmt: skip
        px, py, pz = x, pose[3], z
        t = trans_col[body]
        if t >= 0:  # anchored (DofEncoding.anchored): the body root off its feet, in the heading's frame
            ox, _, oz = _rotate_about_y(heading, pose[t], 0.0, pose[t + 2])
            px, pz = px + ox, pz + oz
        if has_parent:
            qx, qy, qz, qw = parent_inv[0], parent_inv[1], parent_inv[2], parent_inv[3]
            gx, gy, gz, gw = _mul(qx, qy, qz, qw, gx, gy, gz, gw)
            px, py, pz = _rotate(qx, qy, qz, qw, px - parent_pos[0], py - parent_pos[1], pz - parent_pos[2])
        lrot[body, 0], lrot[body, 1], lrot[body, 2], lrot[body, 3] = gx, gy, gz, gw
        ltrans[body, 0], ltrans[body, 1], ltrans[body, 2] = px, py, pz


@njit(cache=True, inline="always")
def _fk(parent, lrot, ltrans, lo, hi, grot, gpos):  # pragma: no cover
    """Global rotations and positions of path joints ``lo ≤ j < hi`` (those above ``lo`` known): ``_fk_kernel.forward``."""
    for j in range(lo, hi):
        p = parent[j]
        if p < 0:
            for k in range(4):
                grot[j, k] = lrot[j, k]
            for k in range(3):
                gpos[j, k] = ltrans[j, k]
            continue
        ax, ay, az, aw = grot[p, 0], grot[p, 1], grot[p, 2], grot[p, 3]
        grot[j, 0], grot[j, 1], grot[j, 2], grot[j, 3] = _mul(ax, ay, az, aw, lrot[j, 0], lrot[j, 1], lrot[j, 2], lrot[j, 3])
        vx, vy, vz = _rotate(ax, ay, az, aw, ltrans[j, 0], ltrans[j, 1], ltrans[j, 2])
        gpos[j, 0] = gpos[p, 0] + vx
        gpos[j, 1] = gpos[p, 1] + vy
        gpos[j, 2] = gpos[p, 2] + vz


@njit(cache=True)
def _reached(
    pose, delta, first, parent, rot_col, reference, chain, lrot, ltrans, grot, gpos, trig, frame, axes, at
):  # pragma: no cover  # fmt: skip
    """The goal joint's measured coordinates ``at (M,)`` with offsets ``delta (K,)`` on the chain: ``goal._Model.reached``
    for one row, the path's global rotations and positions left in ``grot``, ``gpos`` and each chain joint's angle
    ``θ``, ``sin θ/2``, ``cos θ/2`` in ``trig (P, 3)`` (for :func:`_jacobian`). The path above ``first`` is there
    already; the other non-chain joints' local rotations in ``lrot``."""
    p_count = parent.shape[0]
    goal = p_count - 1
    for j in range(first, goal):
        b = chain[j]
        if b >= 0:
            c = rot_col[j]
            rx, ry, rz = pose[c] + delta[3 * b], pose[c + 1] + delta[3 * b + 1], pose[c + 2] + delta[3 * b + 2]
            angle = math.sqrt(rx * rx + ry * ry + rz * rz)  # _pose_kernel._exp, its sine and cosine kept
            half = 0.5 * angle
            sh, ch = math.sin(half), math.cos(half)
            k = 0.5 - angle**2 / 48.0 if angle < 1e-8 else sh / angle
            trig[j, 0], trig[j, 1], trig[j, 2] = angle, sh, ch
            lrot[j, 0], lrot[j, 1], lrot[j, 2], lrot[j, 3] = _mul(
                reference[j, 0], reference[j, 1], reference[j, 2], reference[j, 3], rx * k, ry * k, rz * k, ch
            )
    _fk(parent, lrot, ltrans, first, p_count, grot, gpos)
    tx, ty, tz, tw = frame[0], frame[1], frame[2], frame[3]
    ux, uy, uz = _rotate(tx, ty, tz, tw, gpos[goal, 0] - frame[4], gpos[goal, 1] - frame[5], gpos[goal, 2] - frame[6])
    for m in range(axes.shape[0]):
        at[m] = ux if axes[m] == 0 else (uy if axes[m] == 1 else uz)


@njit(cache=True)
def _jacobian(pose, delta, first, rot_col, chain, grot, gpos, trig, frame, axes, jac):  # pragma: no cover
    """The derivatives ``jac (M, K)`` of the goal joint's measured coordinates with respect to the offsets ``delta``, the
    path's global rotations and positions and the chain's angles at ``delta`` in ``grot``, ``gpos``, ``trig`` (from
    :func:`_reached`): a chain joint's rotation is ``ref · exp(v)``; moving ``v`` by ``δ`` turns it about the world axes
    ``ω = R Jr(v) e_q`` through the joint, which swing the goal joint ``p`` by ``ω × (p − o)``. ``Jr`` is
    ``goal._right_jacobian``'s, with ``1 − cos θ = 2 sin² θ/2`` and ``sin θ = 2 sin θ/2 cos θ/2`` from the forward
    kinematics' half angles (the reference's ``1 − cos θ`` loses digits below θ ≈ 1e-3: they agree to 1e-12 or so)."""
    goal = grot.shape[0] - 1
    tx, ty, tz, tw = frame[0], frame[1], frame[2], frame[3]
    for j in range(first, goal):
        b = chain[j]
        if b < 0:
            continue
        c = rot_col[j]
        vx, vy, vz = pose[c] + delta[3 * b], pose[c + 1] + delta[3 * b + 1], pose[c + 2] + delta[3 * b + 2]
        theta, sh, ch = trig[j, 0], trig[j, 1], trig[j, 2]
        if theta < 1e-4:
            theta2 = theta * theta
            ca = 0.5 - theta2 / 24.0
            cb = 1.0 / 6.0 - theta2 / 120.0
        else:
            ca = 2.0 * sh * sh / (theta * theta)
            cb = (theta - 2.0 * sh * ch) / (theta * theta * theta)
        # Jr(v) = I − a [v]× + b [v]×²; ω × (p − o) = R (Jr e_q × R⁻¹ (p − o)), read in the character's frame T:
        # (T R) (Jr e_q × R⁻¹ (p − o)), one rotation a column.
        qx, qy, qz, qw = grot[j, 0], grot[j, 1], grot[j, 2], grot[j, 3]
        ox, oy, oz = _rotate(-qx, -qy, -qz, qw, gpos[goal, 0] - gpos[j, 0], gpos[goal, 1] - gpos[j, 1],
                             gpos[goal, 2] - gpos[j, 2])  # fmt: skip
        ux, uy, uz, uw = _mul(tx, ty, tz, tw, qx, qy, qz, qw)
        for q in range(3):
            # [v]× e_q and [v]× ([v]× e_q)
            if q == 0:
                kx, ky, kz = 0.0, vz, -vy
            elif q == 1:
                kx, ky, kz = -vz, 0.0, vx
            else:
                kx, ky, kz = vy, -vx, 0.0
            k2x, k2y, k2z = vy * kz - vz * ky, vz * kx - vx * kz, vx * ky - vy * kx
            cx = (1.0 if q == 0 else 0.0) - ca * kx + cb * k2x
            cy = (1.0 if q == 1 else 0.0) - ca * ky + cb * k2y
            cz = (1.0 if q == 2 else 0.0) - ca * kz + cb * k2z
            sx, sy, sz = cy * oz - cz * oy, cz * ox - cx * oz, cx * oy - cy * ox
            rx, ry, rz = _rotate(ux, uy, uz, uw, sx, sy, sz)
            for m in range(axes.shape[0]):
                jac[m, 3 * b + q] = rx if axes[m] == 0 else (ry if axes[m] == 1 else rz)


@njit(cache=True, inline="always")
def _cholesky_solve(a, rhs, x):  # pragma: no cover
    """``x`` with ``A x = rhs`` for a symmetric positive definite ``A`` given by its lower triangle (overwritten by
    its Cholesky factor)."""
    n = rhs.shape[0]
    for j in range(n):
        s = a[j, j]
        for k in range(j):
            s -= a[j, k] * a[j, k]
        d = math.sqrt(s)
        a[j, j] = d
        for r in range(j + 1, n):
            s = a[r, j]
            for k in range(j):
                s -= a[r, k] * a[j, k]
            a[r, j] = s / d
    for r in range(n):
        s = rhs[r]
        for k in range(r):
            s -= a[r, k] * x[k]
        x[r] = s / a[r, r]
    for r in range(n - 1, -1, -1):
        s = x[r]
        for k in range(r + 1, n):
            s -= a[k, r] * x[k]
        x[r] = s / a[r, r]
