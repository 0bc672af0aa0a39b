"""The compiled loop behind :func:`adverbs.kinematics.ik.solve`: the algorithm of ``ik.solve_reference``, pose by pose.

Every step mirrors the NumPy reference (same order of operations), so the two agree to rounding;
a test holds them to it.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .._scratch_kernel import carve


@njit(cache=True, inline="always")
def _quat_to_mat(q, m):
    x, y, z, w = q[0], q[1], q[2], q[3]
    m[0, 0] = 1 - 2 * (y * y + z * z)
    m[0, 1] = 2 * (x * y - w * z)
    m[0, 2] = 2 * (x * z + w * y)
    m[1, 0] = 2 * (x * y + w * z)
    m[1, 1] = 1 - 2 * (x * x + z * z)
    m[1, 2] = 2 * (y * z - w * x)
    m[2, 0] = 2 * (x * z - w * y)
    m[2, 1] = 2 * (y * z + w * x)
    m[2, 2] = 1 - 2 * (x * x + y * y)


@njit(cache=True, _nrt=False)
def _mat_to_quat(m, q):
    t0, t1, t2 = m[0, 0], m[1, 1], m[2, 2]
    tr = t0 + t1 + t2
    r21, r12, r02, r20, r10, r01 = m[2, 1], m[1, 2], m[0, 2], m[2, 0], m[1, 0], m[0, 1]
    k = 0
    best = t0
    if t1 > best:
        k, best = 1, t1
    if t2 > best:
        k, best = 2, t2
    if tr > best:
        k = 3
    if k == 3:
        s = math.sqrt(max(1.0 + tr, 1e-300))
        inv = 0.5 / s
        q[0], q[1], q[2], q[3] = (r21 - r12) * inv, (r02 - r20) * inv, (r10 - r01) * inv, 0.5 * s
    elif k == 0:
        s = math.sqrt(max(1.0 + 2.0 * t0 - tr, 1e-300))
        inv = 0.5 / s
        q[0], q[1], q[2], q[3] = 0.5 * s, (r10 + r01) * inv, (r02 + r20) * inv, (r21 - r12) * inv
    elif k == 1:
        s = math.sqrt(max(1.0 + 2.0 * t1 - tr, 1e-300))
        inv = 0.5 / s
        q[0], q[1], q[2], q[3] = (r10 + r01) * inv, 0.5 * s, (r21 + r12) * inv, (r02 - r20) * inv
    else:
        s = math.sqrt(max(1.0 + 2.0 * t2 - tr, 1e-300))
        inv = 0.5 / s
        q[0], q[1], q[2], q[3] = (r02 + r20) * inv, (r21 + r12) * inv, 0.5 * s, (r10 - r01) * inv


@njit(cache=True, inline="always")
def _copy33(a, out):
    """``out[:] = a`` of two 3×3 matrices, element by element: a slice copy may allocate a temporary, which the
    functions compiled without reference counting cannot (see ``runtime._frame_kernel``)."""
    for i in range(3):
        for j in range(3):
            out[i, j] = a[i, j]


@njit(cache=True, inline="always")
def _mm(a, b, out):
    for i in range(3):
        for j in range(3):
            out[i, j] = a[i, 0] * b[0, j] + a[i, 1] * b[1, j] + a[i, 2] * b[2, j]


@njit(cache=True, inline="always")
def _mtm(a, b, out):
    """aᵀ b"""
    for i in range(3):
        for j in range(3):
            out[i, j] = a[0, i] * b[0, j] + a[1, i] * b[1, j] + a[2, i] * b[2, j]


@njit(cache=True, inline="always")
def _mv(a, v, out):
    for i in range(3):
        out[i] = a[i, 0] * v[0] + a[i, 1] * v[1] + a[i, 2] * v[2]


@njit(cache=True, inline="always")
def _rotation(ax, ay, az, angle, out):
    """Rotation matrix about the unit axis (ax, ay, az) by ``angle`` (Rodrigues)."""
    s, c = math.sin(angle), 1.0 - math.cos(angle)
    out[0, 0] = 1.0 + c * (-az * az - ay * ay)
    out[0, 1] = -s * az + c * ax * ay
    out[0, 2] = s * ay + c * ax * az
    out[1, 0] = s * az + c * ax * ay
    out[1, 1] = 1.0 + c * (-az * az - ax * ax)
    out[1, 2] = -s * ax + c * ay * az
    out[2, 0] = -s * ay + c * ax * az
    out[2, 1] = s * ax + c * ay * az
    out[2, 2] = 1.0 + c * (-ay * ay - ax * ax)


@njit(cache=True, _nrt=True)  # allocates: counts even when its caller is compiled without counting
def solve_batch(
    rot, trans, targets, tilts, above, upper, middle, end, hinge, o_u, o_e, tip, reach, min_flex,
    iterations, lam2, max_step, converged, max_drop, drop_out, resid_out,
):  # fmt: skip
    buf = np.empty(7 * 9 + 6 * 3 + len(end) * 33)
    _solve_batch(
        rot, trans, targets, tilts, above, upper, middle, end, hinge, o_u, o_e, tip, reach, min_flex, iterations, lam2,
        max_step, converged, max_drop, drop_out, resid_out, buf,
    )  # fmt: skip


@njit(cache=True, _nrt=False)
def _solve_batch(
    rot, trans, targets, tilts, above, upper, middle, end, hinge, o_u, o_e, tip, reach, min_flex,
    iterations, lam2, max_step, converged, max_drop, drop_out, resid_out, buf,
):  # fmt: skip
    """:func:`solve_batch` in its working array ``buf`` (not counted: see ``runtime._frame_kernel``)."""
    n_legs = len(end)
    g, at = carve(buf, 0, (3, 3))
    outer, at = carve(buf, at, (3, 3))
    tmp, at = carve(buf, at, (3, 3))
    tmp2, at = carve(buf, at, (3, 3))
    rj, at = carve(buf, at, (3, 3))
    g_u, at = carve(buf, at, (3, 3))
    step, at = carve(buf, at, (3, 3))
    p, at = carve(buf, at, (3,))
    v3, at = carve(buf, at, (3,))
    shin, at = carve(buf, at, (3,))
    knee, at = carve(buf, at, (3,))
    leg, at = carve(buf, at, (3,))
    hg, at = carve(buf, at, (3,))
    hips, at = carve(buf, at, (n_legs, 3))
    goals, at = carve(buf, at, (n_legs, 3))
    l_u, at = carve(buf, at, (n_legs, 3, 3))
    l_m, at = carve(buf, at, (n_legs, 3, 3))
    wanted, at = carve(buf, at, (n_legs, 3, 3))
    for b in range(rot.shape[0]):
        g[:] = 0.0
        g[0, 0] = g[1, 1] = g[2, 2] = 1.0
        p[:] = 0.0
        for j in above:
            _copy33(g, outer)
            _mv(g, trans[b, j], v3)
            for a in range(3):
                p[a] += v3[a]
            _quat_to_mat(rot[b, j], rj)
            _mm(g, rj, tmp)
            _copy33(tmp, g)
        drop = max(drop_out[b], 0.0)  # comes in holding the smallest drop asked for
        for i in range(n_legs):
            _mv(g, trans[b, upper[i]], v3)
            for a in range(3):
                hips[i, a] = p[a] + v3[a]
            _quat_to_mat(rot[b, upper[i]], l_u[i])
            _quat_to_mat(rot[b, middle[i]], l_m[i])
            _quat_to_mat(rot[b, end[i]], rj)
            _mm(g, l_u[i], tmp)
            _mm(tmp, l_m[i], tmp2)
            _mm(tmp2, rj, tmp)
            if tilts.shape[0] > 0:
                _mm(tilts[b, i], tmp, wanted[i])
            else:
                _copy33(tmp, wanted[i])
            _mv(wanted[i], tip[i], v3)
            for a in range(3):
                goals[i, a] = targets[b, i, a] - v3[a]
            dx, dy, dz = goals[i, 0] - hips[i, 0], goals[i, 1] - hips[i, 1], goals[i, 2] - hips[i, 2]
            horizontal = math.sqrt(dx * dx + dz * dz)
            if horizontal < reach[i]:
                need = -dy - math.sqrt(max(reach[i] * reach[i] - horizontal * horizontal, 0.0))
                drop = max(drop, need)
        drop = min(drop, max_drop)
        if drop > 0.0:
            lift = above[len(above) - 1]
            for k in range(3):  # world up, expressed in the pelvis's parent frame (row 1 of outerᵀ)
                trans[b, lift, k] -= drop * outer[1, k]
            for i in range(n_legs):
                hips[i, 1] -= drop
        drop_out[b] = drop

        for i in range(n_legs):
            _mm(g, l_u[i], g_u)
            hx, hy, hz = hinge[i, 0], hinge[i, 1], hinge[i, 2]
            for _ in range(iterations):
                _mv(l_m[i], o_e[i], shin)
                _mv(g_u, o_u[i], v3)
                for a in range(3):
                    knee[a] = hips[i, a] + v3[a]
                _mv(g_u, shin, leg)
                rx = goals[i, 0] - knee[0] - leg[0]
                ry = goals[i, 1] - knee[1] - leg[1]
                rz = goals[i, 2] - knee[2] - leg[2]
                ux, uy, uz = o_u[i, 0], o_u[i, 1], o_u[i, 2]
                ax, ay, az = uy * shin[2] - uz * shin[1], uz * shin[0] - ux * shin[2], ux * shin[1] - uy * shin[0]
                flex = math.atan2(hx * ax + hy * ay + hz * az, ux * shin[0] + uy * shin[1] + uz * shin[2])
                if math.sqrt(rx * rx + ry * ry + rz * rz) <= converged and flex >= min_flex:
                    break  # at its target, knee bent enough: no later iteration would move it (ik.CONVERGED)
                vx = knee[0] + leg[0] - hips[i, 0]
                vy = knee[1] + leg[1] - hips[i, 1]
                vz = knee[2] + leg[2] - hips[i, 2]
                _mv(g_u, hinge[i], hg)
                cx = hg[1] * leg[2] - hg[2] * leg[1]
                cy = hg[2] * leg[0] - hg[0] * leg[2]
                cz = hg[0] * leg[1] - hg[1] * leg[0]
                alpha = vx * vx + vy * vy + vz * vz + lam2
                vr = (vx * rx + vy * ry + vz * rz) / lam2
                brx, bry, brz = (rx + vx * vr) / alpha, (ry + vy * vr) / alpha, (rz + vz * vr) / alpha
                vc = (vx * cx + vy * cy + vz * cz) / lam2
                bcx, bcy, bcz = (cx + vx * vc) / alpha, (cy + vy * vc) / alpha, (cz + vz * vc) / alpha
                f = (cx * brx + cy * bry + cz * brz) / (1.0 + cx * bcx + cy * bcy + cz * bcz)
                yx, yy, yz = brx - bcx * f, bry - bcy * f, brz - bcz * f
                sx, sy, sz = vy * yz - vz * yy, vz * yx - vx * yz, vx * yy - vy * yx
                ks = cx * yx + cy * yy + cz * yz
                size = math.sqrt(sx * sx + sy * sy + sz * sz + ks * ks)
                shrink = min(1.0, max_step / max(size, 1e-12))
                sx, sy, sz, ks = sx * shrink, sy * shrink, sz * shrink, ks * shrink
                angle = math.sqrt(sx * sx + sy * sy + sz * sz)
                if angle >= 1e-12:
                    _rotation(sx / angle, sy / angle, sz / angle, angle, step)
                    _mm(step, g_u, tmp)
                    _copy33(tmp, g_u)
                # knee about its hinge, flexion kept at or above min_flex
                turn = max(flex + ks, min_flex) - flex
                _rotation(hx, hy, hz, turn, step)
                _mm(step, l_m[i], tmp)
                _copy33(tmp, l_m[i])
            _mv(l_m[i], o_e[i], shin)
            for a in range(3):
                shin[a] += o_u[i, a]
            _mv(g_u, shin, v3)
            dx, dy, dz = (
                goals[i, 0] - hips[i, 0] - v3[0],
                goals[i, 1] - hips[i, 1] - v3[1],
                goals[i, 2] - hips[i, 2] - v3[2],
            )
            resid_out[b, i] = math.sqrt(dx * dx + dy * dy + dz * dz)
            _mtm(g, g_u, tmp)
            _mat_to_quat(tmp, rot[b, upper[i]])
            _mat_to_quat(l_m[i], rot[b, middle[i]])
            _mm(g_u, l_m[i], tmp)
            _mtm(tmp, wanted[i], tmp2)
            _mat_to_quat(tmp2, rot[b, end[i]])
