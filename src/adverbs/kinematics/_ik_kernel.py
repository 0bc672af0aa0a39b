"""The compiled loop behind :func:`adverbs.kinematics.ik.solve`: the closed-form two-bone solve of
``ik.solve_reference``, pose by pose.

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
    _turn(ax, ay, az, math.sin(angle), 1.0 - math.cos(angle), out)


@njit(cache=True, inline="always")
def _turn(ax, ay, az, s, c, out):
    """``I + s K + c K²``, ``K`` the cross-product matrix of (ax, ay, az): about a unit axis, the rotation whose angle
    has sine ``s`` and ``1 − cos`` ``c`` (Rodrigues); about ``v × w`` of unit vectors with ``s = 1`` and
    ``c = 1 / (1 + v · w)``, the least rotation taking ``v`` onto ``w``."""
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
    rot, trans, targets, tilts, above, upper, middle, end, hinge, o_u, o_e, tip, reach, min_flex, converged, max_drop,
    drop_out, resid_out,
):  # fmt: skip
    buf = np.empty(7 * 9 + 4 * 3 + len(end) * 33)
    _solve_batch(
        rot, trans, targets, tilts, above, upper, middle, end, hinge, o_u, o_e, tip, reach, min_flex, converged,
        max_drop, drop_out, resid_out, buf,
    )  # fmt: skip


@njit(cache=True, _nrt=False)
def _solve_batch(
    rot, trans, targets, tilts, above, upper, middle, end, hinge, o_u, o_e, tip, reach, min_flex, converged, max_drop,
    drop_out, resid_out, buf,
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
    leg, at = carve(buf, at, (3,))
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
            ux, uy, uz = o_u[i, 0], o_u[i, 1], o_u[i, 2]
            _mv(l_m[i], o_e[i], shin)
            sx, sy, sz = shin[0], shin[1], shin[2]
            v3[0], v3[1], v3[2] = ux + sx, uy + sy, uz + sz
            _mv(g_u, v3, leg)
            rx = goals[i, 0] - hips[i, 0] - leg[0]
            ry = goals[i, 1] - hips[i, 1] - leg[1]
            rz = goals[i, 2] - hips[i, 2] - leg[2]
            ax, ay, az = uy * sz - uz * sy, uz * sx - ux * sz, ux * sy - uy * sx
            flex = math.atan2(hx * ax + hy * ay + hz * az, ux * sx + uy * sy + uz * sz)
            if not (math.sqrt(rx * rx + ry * ry + rz * rz) <= converged and flex >= min_flex):
                # The knee about its hinge by the θ that gives the target's distance (ik.solve_reference).
                along = hx * sx + hy * sy + hz * sz
                lx, ly, lz = along * hx, along * hy, along * hz
                cx, cy, cz = sx - lx, sy - ly, sz - lz
                tx, ty, tz = hy * sz - hz * sy, hz * sx - hx * sz, hx * sy - hy * sx
                ka = ux * lx + uy * ly + uz * lz
                kb = ux * cx + uy * cy + uz * cz
                kc = ux * tx + uy * ty + uz * tz
                px, py, pz = uy * cz - uz * cy, uz * cx - ux * cz, ux * cy - uy * cx
                kp = hx * px + hy * py + hz * pz
                qx, qy, qz = uy * tz - uz * ty, uz * tx - ux * tz, ux * ty - uy * tx
                kq = hx * qx + hy * qy + hz * qz
                ox, oy, oz = goals[i, 0] - hips[i, 0], goals[i, 1] - hips[i, 1], goals[i, 2] - hips[i, 2]
                k = 0.5 * ((ox * ox + oy * oy + oz * oz) - (ux * ux + uy * uy + uz * uz) - (sx * sx + sy * sy + sz * sz))
                radius = math.sqrt(kb * kb + kc * kc)
                flat = radius < 1e-12
                if flat:
                    radius = 1.0
                x = min(max((k - ka) / radius, -1.0), 1.0)
                cos_a, sin_a = x, math.sqrt(1.0 - x * x)
                cos_p, sin_p = kb / radius, kc / radius
                cos_1, sin_1 = cos_p * cos_a - sin_p * sin_a, sin_p * cos_a + cos_p * sin_a
                cos_2, sin_2 = cos_p * cos_a + sin_p * sin_a, sin_p * cos_a - cos_p * sin_a
                ok_1 = math.atan2(kp * cos_1 + kq * sin_1, ka + kb * cos_1 + kc * sin_1) >= min_flex
                ok_2 = math.atan2(kp * cos_2 + kq * sin_2, ka + kb * cos_2 + kc * sin_2) >= min_flex
                if ok_1 and (not ok_2 or cos_1 >= cos_2):
                    cos_t, sin_t = cos_1, sin_1
                else:
                    cos_t, sin_t = cos_2, sin_2
                if not (ok_1 or ok_2) or flat:  # at or past its reach: flexion min_flex, the leg aimed at it
                    turn = min_flex - flex
                    cos_t, sin_t = math.cos(turn), math.sin(turn)
                _turn(hx, hy, hz, sin_t, 1.0 - cos_t, step)
                _mm(step, l_m[i], tmp)
                _copy33(tmp, l_m[i])
                # The hip: the least rotation taking the leg's direction onto the target's.
                _mv(l_m[i], o_e[i], shin)
                v3[0], v3[1], v3[2] = ux + shin[0], uy + shin[1], uz + shin[2]
                _mv(g_u, v3, leg)
                n = math.sqrt(leg[0] * leg[0] + leg[1] * leg[1] + leg[2] * leg[2])
                vx, vy, vz = leg[0] / n, leg[1] / n, leg[2] / n
                n = max(math.sqrt(ox * ox + oy * oy + oz * oz), 1e-300)
                wx, wy, wz = ox / n, oy / n, oz / n
                cos_s = vx * wx + vy * wy + vz * wz
                if not (1.0 + cos_s < 1e-12):
                    _turn(vy * wz - vz * wy, vz * wx - vx * wz, vx * wy - vy * wx, 1.0, 1.0 / (1.0 + cos_s), step)
                    _mm(step, g_u, tmp)
                    _copy33(tmp, g_u)
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
