"""The compiled loop behind :func:`adverbs.kinematics.fk.forward_kinematics`: pose by pose, joint by joint.

The arithmetic is :func:`adverbs.kinematics.quat.mul` and :func:`~adverbs.kinematics.quat.rotate` written out
in the same order, so it agrees with the NumPy reference (``fk.forward_kinematics_reference``, one depth level
at a time) to rounding; a test holds them to it. One call costs microseconds where the reference pays a
NumPy call per level and operation: what a run-time frame of one creature needs.
"""

from __future__ import annotations

from numba import njit


@njit(cache=True, _nrt=False)
def forward(parents, rotations, translations, positions, global_rotations):  # pragma: no cover - compiled
    """``rotations (N, J, 4)``, ``translations (N, J, 3)`` local → ``positions``, ``global_rotations`` (filled)."""
    n, j = rotations.shape[0], rotations.shape[1]
    for f in range(n):
        _root(f, rotations, translations, positions, global_rotations)
        for i in range(1, j):
            _joint(f, i, parents[i], rotations, translations, positions, global_rotations)


@njit(cache=True, _nrt=False)
def forward_to(parents, joints, rotations, translations, positions, global_rotations):  # pragma: no cover - compiled
    """:func:`forward` of the root and ``joints (K,)`` alone (ascending, each one's parent the root or among them:
    :func:`adverbs.kinematics.fk.path_to`), the same numbers for those; the other joints' rows are left as they were."""
    for f in range(rotations.shape[0]):
        _root(f, rotations, translations, positions, global_rotations)
        for k in range(joints.shape[0]):
            i = joints[k]
            _joint(f, i, parents[i], rotations, translations, positions, global_rotations)


@njit(cache=True, inline="always")
def _root(f, rotations, translations, positions, global_rotations):  # pragma: no cover - compiled
    for k in range(4):
        global_rotations[f, 0, k] = rotations[f, 0, k]
    for k in range(3):
        positions[f, 0, k] = translations[f, 0, k]


@njit(cache=True, inline="always")
def _joint(f, i, p, rotations, translations, positions, global_rotations):  # pragma: no cover - compiled
    ax, ay, az, aw = global_rotations[f, p, 0], global_rotations[f, p, 1], global_rotations[f, p, 2], global_rotations[f, p, 3]
    bx, by, bz, bw = rotations[f, i, 0], rotations[f, i, 1], rotations[f, i, 2], rotations[f, i, 3]
    global_rotations[f, i, 0] = aw * bx + ax * bw + ay * bz - az * by
    global_rotations[f, i, 1] = aw * by - ax * bz + ay * bw + az * bx
    global_rotations[f, i, 2] = aw * bz + ax * by - ay * bx + az * bw
    global_rotations[f, i, 3] = aw * bw - ax * bx - ay * by - az * bz
    vx, vy, vz = translations[f, i, 0], translations[f, i, 1], translations[f, i, 2]
    tx = 2.0 * (ay * vz - az * vy)
    ty = 2.0 * (az * vx - ax * vz)
    tz = 2.0 * (ax * vy - ay * vx)
    positions[f, i, 0] = positions[f, p, 0] + (vx + aw * tx + ay * tz - az * ty)
    positions[f, i, 1] = positions[f, p, 1] + (vy + aw * ty + az * tx - ax * tz)
    positions[f, i, 2] = positions[f, p, 2] + (vz + aw * tz + ax * ty - ay * tx)
