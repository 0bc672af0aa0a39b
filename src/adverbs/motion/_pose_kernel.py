"""Compiled loops behind :meth:`adverbs.motion.encoding.DofEncoding.decode_pose` (log-quaternion DOFs) and the
rotation blend of a verb graph's transitions (:func:`blend_poses`), pose by pose, joint by joint.

The arithmetic is that of :func:`adverbs.kinematics.quat.exp`, :func:`~adverbs.kinematics.quat.mul`,
:func:`~adverbs.kinematics.quat.rotate` and :func:`~adverbs.kinematics.quat.slerp` written out in the same
order, so the results agree with the NumPy references (``DofEncoding._decode_pose_reference``, ``quat.slerp``)
to rounding; tests hold them to it. One call costs microseconds where the references pay a NumPy call per
operation: what a run-time frame of one creature needs.
"""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True, inline="always")
def _mul(ax, ay, az, aw, bx, by, bz, bw):  # pragma: no cover - compiled
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


@njit(cache=True, inline="always")
def _rotate(x, y, z, w, vx, vy, vz):  # pragma: no cover - compiled
    """``quat.rotate`` of one vector, the same arithmetic."""
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return vx + w * tx + y * tz - z * ty, vy + w * ty + z * tx - x * tz, vz + w * tz + x * ty - y * tx


@njit(cache=True, inline="always")
def _exp(rx, ry, rz):  # pragma: no cover - compiled
    angle = math.sqrt(rx * rx + ry * ry + rz * rz)
    half = 0.5 * angle
    k = 0.5 - angle**2 / 48.0 if angle < 1e-8 else math.sin(half) / angle
    return rx * k, ry * k, rz * k, math.cos(half)


@njit(cache=True, inline="always")
def _log(x, y, z, w):  # pragma: no cover - compiled
    s = math.sqrt(x * x + y * y + z * z)
    scale = 2.0 / w if s < 1e-8 else 2.0 * math.atan2(s, w) / s
    return x * scale, y * scale, z * scale


@njit(cache=True)
def decode_logquat(
    dofs, roots, rows, rotated, reference, translated, base, body, parent_inv, parent_pos, has_parent, out_rot, out_trans
):  # pragma: no cover - compiled
    """Poses ``dofs (n, D)`` at body roots ``roots (n, 3)`` = ``(x, z, heading)`` into rows ``rows (n,)`` of
    ``out_rot (C, J, 4)`` and ``out_trans (C, J, 3)``: every joint of those rows is written.

    ``rotated (R,)``: joints with rotation columns (body root first), each ``reference[j] · exp(d)``;
    ``translated (T,)``: joints with translation columns (``base[j] + d``); the rest keep the identity and
    ``base``. The body root turned by the heading and placed at ``(x, root.y, z)``, expressed below its fixed
    ancestors (``parent_inv``, the inverse of their global rotation, and ``parent_pos``, their position) when
    ``has_parent``.
    """
    for i in range(dofs.shape[0]):
        decode_row(
            dofs[i], roots[i, 0], roots[i, 1], roots[i, 2], rotated, reference, translated, base, body, parent_inv,
            parent_pos, has_parent, out_rot[rows[i]], out_trans[rows[i]],
        )  # fmt: skip


@njit(cache=True, inline="always")
def decode_row(
    dofs, x, z, heading, rotated, reference, translated, base, body, parent_inv, parent_pos, has_parent, out_rot, out_trans
):  # pragma: no cover - compiled
    """One pose of :func:`decode_logquat`: ``dofs (D,)`` at the body root ``(x, z, heading)`` into ``out_rot (J, 4)`` and
    ``out_trans (J, 3)``."""
    j_count = base.shape[0]
    r_count = rotated.shape[0]
    for j in range(j_count):
        out_rot[j, 0] = 0.0
        out_rot[j, 1] = 0.0
        out_rot[j, 2] = 0.0
        out_rot[j, 3] = 1.0
        for a in range(3):
            out_trans[j, a] = base[j, a]
    for k in range(r_count):
        j = rotated[k]
        c = 4 + 3 * k
        ex, ey, ez, ew = _exp(dofs[c], dofs[c + 1], dofs[c + 2])
        qx, qy, qz, qw = _mul(reference[j, 0], reference[j, 1], reference[j, 2], reference[j, 3], ex, ey, ez, ew)
        out_rot[j, 0] = qx
        out_rot[j, 1] = qy
        out_rot[j, 2] = qz
        out_rot[j, 3] = qw
    for k in range(translated.shape[0]):
        j = translated[k]
        c = 4 + 3 * r_count + 3 * k
        for a in range(3):
            out_trans[j, a] = base[j, a] + dofs[c + a]
    half = 0.5 * heading
    gx, gy, gz, gw = _mul(
        0.0, math.sin(half), 0.0, math.cos(half), out_rot[body, 0], out_rot[body, 1], out_rot[body, 2], out_rot[body, 3]
    )
    px, py, pz = x, dofs[3], z
    for k in range(translated.shape[0]):
        if translated[k] == body:  # anchored (DofEncoding.anchored): the body root off its feet, in the heading's frame
            c = 4 + 3 * r_count + 3 * k
            ox, _, oz = _rotate_about_y(heading, dofs[c], 0.0, dofs[c + 2])
            px, pz = px + ox, pz + oz
    if has_parent:
        x, y, z, w = parent_inv[0], parent_inv[1], parent_inv[2], parent_inv[3]
        gx, gy, gz, gw = _mul(x, y, z, w, gx, gy, gz, gw)
        vx, vy, vz = px - parent_pos[0], py - parent_pos[1], pz - parent_pos[2]
        tx = 2.0 * (y * vz - z * vy)
        ty = 2.0 * (z * vx - x * vz)
        tz = 2.0 * (x * vy - y * vx)
        px, py, pz = vx + w * tx + y * tz - z * ty, vy + w * ty + z * tx - x * tz, vz + w * tz + x * ty - y * tx
    out_rot[body, 0] = gx
    out_rot[body, 1] = gy
    out_rot[body, 2] = gz
    out_rot[body, 3] = gw
    out_trans[body, 0] = px
    out_trans[body, 1] = py
    out_trans[body, 2] = pz


@njit(cache=True)
def blend_poses(rot, trans, rot_b, trans_b, rows, w):  # pragma: no cover - compiled
    """Rows ``rows (n,)`` of ``rot (C, J, 4)``, ``trans (C, J, 3)`` blended in place with ``rot_b``, ``trans_b``:
    ``slerp(b, a, w)`` on every rotation and ``w a + (1 − w) b`` on every translation, ``w (n,)`` per row
    (``quat.slerp`` the short way round, then normalized). At ``w = 0`` the rows are B's (A's may be unset)."""
    for i in range(rows.shape[0]):
        blend_row(rot[rows[i]], trans[rows[i]], rot_b[rows[i]], trans_b[rows[i]], w[i])


@njit(cache=True, inline="always")
def blend_row(rot, trans, rot_b, trans_b, u):  # pragma: no cover - compiled
    """One pose of :func:`blend_poses`: ``rot (J, 4)``, ``trans (J, 3)`` blended in place with B's at weight ``u``."""
    for j in range(rot.shape[0]):
        bx, by, bz, bw = rot_b[j, 0], rot_b[j, 1], rot_b[j, 2], rot_b[j, 3]
        if u == 0.0:
            n = math.sqrt(bx * bx + by * by + bz * bz + bw * bw)
            rot[j, 0], rot[j, 1], rot[j, 2], rot[j, 3] = bx / n, by / n, bz / n, bw / n
            for a in range(3):
                trans[j, a] = trans_b[j, a]
            continue
        ax, ay, az, aw = rot[j, 0], rot[j, 1], rot[j, 2], rot[j, 3]
        if bx * ax + by * ay + bz * az + bw * aw < 0.0:  # slerp(b, a): a flipped onto b's side
            ax, ay, az, aw = -ax, -ay, -az, -aw
        dx, dy, dz, dw = _mul(-bx, -by, -bz, bw, ax, ay, az, aw)
        lx, ly, lz = _log(dx, dy, dz, dw)
        ex, ey, ez, ew = _exp(lx * u, ly * u, lz * u)
        qx, qy, qz, qw = _mul(bx, by, bz, bw, ex, ey, ez, ew)
        n = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
        rot[j, 0], rot[j, 1], rot[j, 2], rot[j, 3] = qx / n, qy / n, qz / n, qw / n
        for a in range(3):
            trans[j, a] = u * trans[j, a] + (1.0 - u) * trans_b[j, a]


@njit(cache=True, inline="always")
def _rotate_about_y(angle, vx, vy, vz):  # pragma: no cover - compiled
    """``quat.rotate(quat.about_y(angle), v)`` written out, zeros and all (the same rounding)."""
    half = 0.5 * angle
    x, y, z, w = 0.0, math.sin(half), 0.0, math.cos(half)
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return vx + w * tx + y * tz - z * ty, vy + w * ty + z * tx - x * tz, vz + w * tz + x * ty - y * tx


@njit(cache=True, inline="always")
def advance_root_row(x, z, heading, vx, vz, turn, dt):  # pragma: no cover - compiled
    """One root of :func:`advance_roots`: ``(x, z, heading)`` moved on by ``dt`` at ``(vx, vz, turn)``."""
    h1 = heading + turn * dt
    sx, _, sz = _rotate_about_y(0.5 * (heading + h1), vx, 0.0, vz)
    return x + sx * dt, z + sz * dt, h1


@njit(cache=True, inline="always")
def root_velocity_row(x0, z0, h0, x1, z1, h1, dt):  # pragma: no cover - compiled
    """One row of :func:`root_velocities`: the velocities taking root ``(x0, z0, h0)`` to ``(x1, z1, h1)`` in ``dt``."""
    vx, _, vz = _rotate_about_y(-0.5 * (h0 + h1), (x1 - x0) / dt, 0.0, (z1 - z0) / dt)
    return vx, vz, (h1 - h0) / dt


@njit(cache=True)
def advance_roots(root, velocity, dt, out):  # pragma: no cover - compiled
    """:func:`adverbs.motion.encoding.advance_root` of roots ``(n, 3)`` at velocities ``(n, 3)`` by ``dt`` into ``out``."""
    for i in range(root.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = advance_root_row(
            root[i, 0], root[i, 1], root[i, 2], velocity[i, 0], velocity[i, 1], velocity[i, 2], dt
        )


@njit(cache=True)
def root_velocities(old, new, dt, out):  # pragma: no cover - compiled
    """The velocities ``(n, 3)`` (sideways, forward, turn) taking roots ``old`` to ``new`` in ``dt``, into ``out``:
    the inverse of :func:`advance_roots`."""
    for i in range(old.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = root_velocity_row(
            old[i, 0], old[i, 1], old[i, 2], new[i, 0], new[i, 1], new[i, 2], dt
        )
