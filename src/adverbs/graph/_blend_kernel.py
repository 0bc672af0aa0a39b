"""Compiled loops behind two parts of a verb graph's step that concern only the creatures in a blend:
:func:`keep_feet` (``player._keep_feet``: the body carried by the held feet's slip) and :func:`decay_offsets`
(an inertial blend's or an interruption's decaying pose offset added to the pose).

The arithmetic is that of the NumPy code they replace (forward kinematics as :mod:`adverbs.kinematics._fk_kernel`
has it, :func:`adverbs.kinematics.quat.rotate`, ``quat.exp``, ``quat.mul`` and the critically damped spring), in the
same order; tests hold them to it. A creature in a blend pays a few microseconds here instead of dozens of NumPy calls.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..kinematics._fk_kernel import forward_to
from ..motion._pose_kernel import _exp, _mul, _rotate_about_y
from ..feet._planting_scalars import spring


@njit(cache=True)
def keep_feet(parents, tips, path, rows, weights, rot, trans, shown_rot, shown_trans, shown_vel, body, above_inv, root, prev,
              lo, hi, change, fade, dt, held_back):  # pragma: no cover  # fmt: skip
    """For each creature ``rows[i]`` with foot weights ``weights[i] (L,)`` (where they sum to more than zero): the weighted mean
    horizontal slip ``was − now`` of its feet ``tips (L,)`` between the pose shown before (``shown_rot``,
    ``shown_trans``) and this one (``rot``, ``trans``), added to its ``root (C, 3)`` = ``(x, z, heading)`` and, in
    the frame above the body root (``above_inv``, the inverse of its rest rotation), to the body root's translation;
    the root's velocity held within ``change[i]`` m/s² of the one shown, ``shown_vel (C, 3)``, and its step from
    ``prev (C, 3)`` to ``lo[i]`` to ``hi[i]`` m/s, the slip scaled by ``fade[i]`` (see :func:`keep_feet_row`);
    ``held_back[i]``: whether ``change[i]`` held its velocity back."""
    n_j = parents.shape[0]
    now_pos, now_rot = np.empty((1, n_j, 3)), np.empty((1, n_j, 4))
    was_pos, was_rot = np.empty((1, n_j, 3)), np.empty((1, n_j, 4))
    for i in range(rows.shape[0]):
        c = rows[i]
        held_back[i] = keep_feet_row(
            parents, tips, path, weights[i], rot[c : c + 1], trans[c : c + 1], shown_rot[c : c + 1], shown_trans[c : c + 1],
            body, above_inv, root[c], now_pos, now_rot, was_pos, was_rot, prev[c, 0], prev[c, 1], prev[c, 2],
            shown_vel[c, 0], shown_vel[c, 1], shown_vel[c, 2], lo[i], hi[i], change[i], fade[i], dt,
        )  # fmt: skip


@njit(cache=True, inline="always")
def keep_feet_row(parents, tips, path, weights, rot, trans, shown_rot, shown_trans, body, above_inv, root, now_pos, now_rot,
                  was_pos, was_rot, x0, z0, h0, svx, svz, sturn, lo, hi, change, fade, dt):  # pragma: no cover  # fmt: skip
    """One creature of :func:`keep_feet`: its pose ``rot (1, J, 4)``, ``trans (1, J, 3)``, the one shown before, its
    ``root (3,)``; ``now_*``, ``was_*``: forward kinematics' scratch ``(1, J, 3)``, ``(1, J, 4)``.

    Its step from ``(x0, z0)`` (carried by held feet, or the root's own) is held to ``lo`` to ``hi`` m/s, along the
    root's advance by the blended velocities (``0`` and ``inf``: any); then its velocity is held within ``change``
    m/s² of the one shown before, ``(svx, svz, sturn)`` (sideways, forward, turn; its step ended at heading ``h0``),
    held feet or none: under a decaying offset the body goes where its feet take it, only not at once (``inf``: at
    once), and a carry that ends eases back to the root's own velocity. In a cosine blend of two verbs the graph
    holds it to the speed of the blend of their own velocities, ``|α v_A + (1 − α) v_B|``: carried by the whole slip of feet the verbs stand at different
    places under the body, a run braked nearly to a standstill on its way into a walk, and a start threw the body
    past the walk's speed. The legs take up the rest (the planter holds the feet, and re-places one left behind).
    ``fade``: how much of the slip carries the body (1 in a cosine blend; under a decaying offset, as much as is left
    of it). Returns whether ``change`` held the velocity back (the body lags the velocity it was carried to).
    """
    total = 0.0
    for k in range(tips.shape[0]):
        total += weights[k]
    sx = 0.0
    sz = 0.0
    if total > 0.0:  # feet held in both frames: the body carried by their slip
        forward_to(parents, path, rot, trans, now_pos, now_rot)  # the feet's ancestors alone (fk.path_to)
        forward_to(parents, path, shown_rot, shown_trans, was_pos, was_rot)
        for k in range(tips.shape[0]):
            w = weights[k]
            sx += w * (was_pos[0, tips[k], 0] - now_pos[0, tips[k], 0])
            sz += w * (was_pos[0, tips[k], 2] - now_pos[0, tips[k], 2])
        sx /= total
        sz /= total
        if fade != 1.0:
            sx *= fade
            sz *= fade
    dx = root[0] + sx - x0
    dz = root[1] + sz - z0
    d = math.sqrt(dx * dx + dz * dz)
    if d > hi * dt or d < lo * dt:  # along the verbs' own way (the root's advance), else the slip's
        ax, az = root[0] - x0, root[1] - z0
        a = math.sqrt(ax * ax + az * az)
        if a > 1e-12:
            ux, uz = ax / a, az / a
        elif d > 1e-12:
            ux, uz = dx / d, dz / d
        else:
            ux, uz = 0.0, 0.0
        m = min(max(d, lo * dt), hi * dt)
        dx, dz = ux * m, uz * m
        sx, sz = x0 + dx - root[0], z0 + dz - root[1]
    # Last, and whether or not a foot is held: a carry that ends (its feet let go, re-placed) does not jump the body
    # back to its own velocity in one frame, nor the speed floor reverse it.
    held_back = False
    if math.isfinite(change):  # the velocity shown before, in the world: its step's heading halfway
        px, _, pz = _rotate_about_y(h0 - 0.5 * sturn * dt, svx, 0.0, svz)
        ex, ez = dx - px * dt, dz - pz * dt
        e = math.sqrt(ex * ex + ez * ez)
        if e > change * dt * dt:
            k = change * dt * dt / e
            dx, dz = px * dt + ex * k, pz * dt + ez * k
            sx, sz = x0 + dx - root[0], z0 + dz - root[1]
            held_back = True
    if sx == 0.0 and sz == 0.0:
        return held_back
    root[0] += sx
    root[1] += sz
    x, y, z, w = above_inv[0], above_inv[1], above_inv[2], above_inv[3]
    tx = 2.0 * (y * sz - z * 0.0)
    ty = 2.0 * (z * sx - x * sz)
    tz = 2.0 * (x * 0.0 - y * sx)
    trans[0, body, 0] += sx + w * tx + y * tz - z * ty
    trans[0, body, 1] += 0.0 + w * ty + z * tx - x * tz
    trans[0, body, 2] += sz + w * tz + x * ty - y * tx
    return held_back


@njit(cache=True)
def decay_offsets(rows, since, halflife, offset_rot, offset_rot_vel, offset_trans, offset_trans_vel, rot, trans):  # pragma: no cover
    """For each creature ``rows[i]``: its offset ``since[i]`` seconds on (half-life ``halflife[i]``), each joint's
    rotation offset (a rotation vector) applied before its rotation and its translation offset added."""
    ln2 = math.log(2.0)
    for i in range(rows.shape[0]):
        c = rows[i]
        decay_row(since[i], halflife[i], offset_rot[c], offset_rot_vel[c], offset_trans[c], offset_trans_vel[c], rot[c],
                  trans[c], ln2)  # fmt: skip


@njit(cache=True, inline="always")
def decay_row(t, h, offset_rot, offset_rot_vel, offset_trans, offset_trans_vel, rot, trans, ln2):  # pragma: no cover
    """One creature of :func:`decay_offsets`: its offsets ``(J, 3)`` ``t`` seconds on, onto ``rot (J, 4)``, ``trans (J, 3)``."""
    for j in range(rot.shape[0]):
        rx = spring(offset_rot[j, 0], offset_rot_vel[j, 0], t, h, ln2)
        ry = spring(offset_rot[j, 1], offset_rot_vel[j, 1], t, h, ln2)
        rz = spring(offset_rot[j, 2], offset_rot_vel[j, 2], t, h, ln2)
        ex, ey, ez, ew = _exp(rx, ry, rz)
        q = _mul(ex, ey, ez, ew, rot[j, 0], rot[j, 1], rot[j, 2], rot[j, 3])
        for a in range(4):
            rot[j, a] = q[a]
        for a in range(3):
            trans[j, a] += spring(offset_trans[j, a], offset_trans_vel[j, a], t, h, ln2)
