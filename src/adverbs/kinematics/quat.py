"""Unit quaternions as arrays ``(..., 4)``, scalar-last ``(x, y, z, w)`` like scipy's ``Rotation``.

Only the operations the hot paths need live here, vectorized over any leading axes; conversions to
and from Euler angles go through ``scipy.spatial.transform.Rotation``.
"""

from __future__ import annotations

import warnings

import numpy as np
from scipy.spatial.transform import Rotation


def identity(shape: tuple[int, ...] = ()) -> np.ndarray:
    """Identity rotations ``shape + (4,)``."""
    q = np.zeros(shape + (4,))
    q[..., 3] = 1.0
    return q


def mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a b`` (apply ``b`` first, then ``a``), broadcasting ``(..., 4)``."""
    ax, ay, az, aw = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bx, by, bz, bw = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return np.stack(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ],
        axis=-1,
    )


def inv(q: np.ndarray) -> np.ndarray:
    """Inverse of unit quaternions ``(..., 4)`` (the conjugate)."""
    return q * np.array([-1.0, -1.0, -1.0, 1.0])


def angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The angle (radians, 0 to π) of the rotation between unit quaternions ``a`` and ``b`` ``(..., 4)``,
    broadcasting: ``2 arccos |a · b|``."""
    return 2.0 * np.arccos(np.minimum(np.abs(np.sum(a * b, axis=-1)), 1.0))


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors ``v (..., 3)`` by unit quaternions ``q (..., 4)``.

    ``v + w t + u × t`` with ``t = 2 u × v``, the cross products written out (``np.cross`` costs
    more than the arithmetic on small arrays).
    """
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    vx, vy, vz = v[..., 0], v[..., 1], v[..., 2]
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return np.stack(
        [vx + w * tx + y * tz - z * ty, vy + w * ty + z * tx - x * tz, vz + w * tz + x * ty - y * tx], axis=-1
    )


def about_y(angle: np.ndarray) -> np.ndarray:
    """Rotations by ``angle (...)`` radians about the vertical Y axis, ``(..., 4)``."""
    half = 0.5 * np.asarray(angle, dtype=float)
    zero = np.zeros_like(half)
    return np.stack([zero, np.sin(half), zero, np.cos(half)], axis=-1)


def between(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The shortest rotations ``(..., 4)`` taking directions ``u`` to ``v`` (``(..., 3)``, any length, broadcasting).
    Opposite directions: a half turn about an axis square to ``u`` (``u × x̂``, or ``u × ŷ`` for ``u`` near X)."""
    u = u / np.linalg.norm(u, axis=-1, keepdims=True)
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    u, v = np.broadcast_arrays(u, v)
    w = 1.0 + np.sum(u * v, axis=-1, keepdims=True)
    q = np.concatenate([np.cross(u, v), w], axis=-1)
    opposite = w[..., 0] < 1e-9
    if np.any(opposite):
        uo = u[opposite]
        other = np.where(np.abs(uo[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
        axis = np.cross(uo, other)
        q[opposite] = np.concatenate([axis / np.linalg.norm(axis, axis=-1, keepdims=True), np.zeros((len(uo), 1))], axis=-1)
    return normalize(q)


def normalize(q: np.ndarray) -> np.ndarray:
    """Scale ``(..., 4)`` to unit length."""
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def make_continuous(q: np.ndarray, axis: int = 0) -> np.ndarray:
    """Flip signs along ``axis`` so consecutive quaternions have non-negative dot products.

    ``q`` and ``-q`` are the same rotation; choosing the sign that stays close to the previous sample
    makes a sequence smooth, which interpolation and the log map need.
    """
    q = np.moveaxis(np.asarray(q, dtype=float), axis, 0).copy()
    if len(q) > 1:
        dots = np.sum(q[1:] * q[:-1], axis=-1)
        flips = np.cumprod(np.where(dots < 0.0, -1.0, 1.0), axis=0)
        q[1:] *= flips[..., None]
    return np.moveaxis(q, 0, axis)


def log(q: np.ndarray) -> np.ndarray:
    """Rotation vectors ``(..., 3)`` (angle times axis) of quaternions ``(..., 4)``.

    Unlike ``Rotation.as_rotvec`` this keeps the quaternion's sign: ``w < 0`` gives an angle in
    ``(π, 2π]``, so a sign-continuous quaternion sequence maps to a continuous curve.
    """
    v = q[..., :3]
    s = np.linalg.norm(v, axis=-1)
    angle = 2.0 * np.arctan2(s, q[..., 3])
    # angle / s → 2 / w as s → 0; the series keeps full precision for tiny rotations.
    small = s < 1e-8
    scale = np.where(small, 2.0 / np.where(small, q[..., 3], 1.0), angle / np.where(small, 1.0, s))
    return v * scale[..., None]


def exp(r: np.ndarray) -> np.ndarray:
    """Quaternions ``(..., 4)`` of rotation vectors ``(..., 3)``; inverse of :func:`log`."""
    angle = np.linalg.norm(r, axis=-1)
    half = 0.5 * angle
    small = angle < 1e-8
    # sin(θ/2)/θ → 1/2 − θ²/48 for small θ.
    k = np.where(small, 0.5 - angle**2 / 48.0, np.sin(half) / np.where(small, 1.0, angle))
    return np.concatenate([r * k[..., None], np.cos(half)[..., None]], axis=-1)


def from_euler(order: str, angles: np.ndarray) -> np.ndarray:
    """Quaternions ``(..., 4)`` from intrinsic Euler angles ``(..., len(order))`` in radians.

    ``order`` is a string of axes such as ``"ZXY"``: the rotation is ``R_Z R_X R_Y``, which is how
    BVH channel lists compose.
    """
    angles = np.asarray(angles, dtype=float)
    shape = angles.shape[:-1]
    flat = angles.reshape(-1, len(order))
    if len(flat) == 0:
        return identity(shape)
    q = Rotation.from_euler(order.upper(), flat).as_quat()
    return q.reshape(shape + (4,))


def to_euler(order: str, q: np.ndarray) -> np.ndarray:
    """Intrinsic Euler angles ``(..., 3)`` in radians of quaternions ``(..., 4)``, principal range."""
    q = np.asarray(q, dtype=float)
    shape = q.shape[:-1]
    flat = q.reshape(-1, 4)
    if len(flat) == 0:
        return np.zeros(shape + (3,))
    # Gimbal-lock warnings are expected on real data; the angles returned are still a valid solution.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        e = Rotation.from_quat(flat).as_euler(order.upper())
    return e.reshape(shape + (3,))


def unwrap_euler(order: str, angles: np.ndarray, axis: int = 0, near: np.ndarray | None = None) -> np.ndarray:
    """Make Euler angle sequences ``(..., 3)`` continuous along ``axis``.

    Every rotation has two Tait–Bryan solutions, ``(a, b, c)`` and ``(a + π, π − b, c + π)``, each
    up to multiples of 2π. At each sample the one nearest the previous sample is chosen, so no
    channel jumps by more than π between samples unless the motion itself does; the first sample
    is the one nearest ``near`` (angles broadcasting against one sample), if given, so that several
    sequences land on the same branch. The loop runs over samples, vectorized over every other axis.
    """
    from ._euler_kernel import unwrap

    del order  # the equivalence holds for every Tait–Bryan order
    a = np.moveaxis(np.asarray(angles, dtype=float), axis, 0)
    shape = a.shape
    flat = np.ascontiguousarray(a.reshape(len(a), -1, 3))
    alt = np.stack([flat[..., 0] + np.pi, np.pi - flat[..., 1], flat[..., 2] + np.pi], axis=-1)
    first = np.zeros(flat.shape[1:]) if near is None else np.broadcast_to(np.asarray(near, dtype=float), shape[1:]).reshape(-1, 3)
    out = unwrap(flat, alt, np.ascontiguousarray(first), 0 if near is not None else 1) if len(a) else flat
    return np.moveaxis(out.reshape(shape), 0, axis)


def slerp(a: np.ndarray, b: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Spherical interpolation from ``a`` to ``b`` (both ``(..., 4)``) by ``u (...)`` in [0, 1], the short way."""
    b = np.where(np.sum(a * b, axis=-1, keepdims=True) < 0.0, -b, b)
    return normalize(mul(a, exp(log(mul(inv(a), b)) * np.asarray(u, dtype=float)[..., None])))


def slerp_frames(q: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """Spherical interpolation of a sampled sequence ``q (F, ..., 4)`` at fractional frame indices.

    ``positions (G,)`` are in frames, clipped to ``[0, F − 1]``; returns ``(G, ..., 4)``.
    """
    q = make_continuous(q, axis=0)
    f = len(q)
    x = np.clip(np.asarray(positions, dtype=float), 0.0, f - 1.0)
    i0 = np.minimum(np.floor(x).astype(int), max(f - 2, 0))
    i1 = np.minimum(i0 + 1, f - 1)
    u = (x - i0).reshape((-1,) + (1,) * (q.ndim - 1))
    a, b = q[i0], q[i1]
    # a⁻¹b as a rotation vector, scaled by u, applied to a: the geodesic from a to b.
    step = exp(log(mul(inv(a), b)) * u)
    return normalize(mul(a, step))


def to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` of unit quaternions ``(..., 4)``."""
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz, wx, wy, wz = x * y, x * z, y * z, w * x, w * y, w * z
    return np.stack(
        [
            1 - 2 * (yy + zz), 2 * (xy - wz), 2 * (xz + wy),
            2 * (xy + wz), 1 - 2 * (xx + zz), 2 * (yz - wx),
            2 * (xz - wy), 2 * (yz + wx), 1 - 2 * (xx + yy),
        ],
        axis=-1,
    ).reshape(q.shape[:-1] + (3, 3))  # fmt: skip


def from_matrix(m: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(..., 4)`` of rotation matrices ``(..., 3, 3)`` (Shepperd's method, stable)."""
    t = np.stack([m[..., 0, 0], m[..., 1, 1], m[..., 2, 2], m[..., 0, 0] + m[..., 1, 1] + m[..., 2, 2]], axis=-1)
    k = np.argmax(t, axis=-1)
    out = np.empty(m.shape[:-2] + (4,))
    s = np.sqrt(np.maximum(1.0 + 2.0 * np.take_along_axis(t, k[..., None], -1)[..., 0] - t[..., 3], 1e-300))
    s = np.where(k == 3, np.sqrt(np.maximum(1.0 + t[..., 3], 1e-300)), s)
    # Largest-component branches; each writes (x, y, z, w) scaled by 1/(2s) except the dominant one.
    r21, r12, r02, r20, r10, r01 = m[..., 2, 1], m[..., 1, 2], m[..., 0, 2], m[..., 2, 0], m[..., 1, 0], m[..., 0, 1]
    inv = 0.5 / s
    cand = np.stack(
        [
            np.stack([0.5 * s, (r10 + r01) * inv, (r02 + r20) * inv, (r21 - r12) * inv], -1),
            np.stack([(r10 + r01) * inv, 0.5 * s, (r21 + r12) * inv, (r02 - r20) * inv], -1),
            np.stack([(r02 + r20) * inv, (r21 + r12) * inv, 0.5 * s, (r10 - r01) * inv], -1),
            np.stack([(r21 - r12) * inv, (r02 - r20) * inv, (r10 - r01) * inv, 0.5 * s], -1),
        ],
        axis=-2,
    )
    out = np.take_along_axis(cand, k[..., None, None], -2)[..., 0, :]
    return out


def cross_matrix(v: np.ndarray) -> np.ndarray:
    """The cross-product matrices ``[v]× (..., 3, 3)`` of vectors ``v (..., 3)``: ``[v]× w = v × w``."""
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    zero = np.zeros_like(x)
    return np.stack([zero, -z, y, z, zero, -x, -y, x, zero], axis=-1).reshape(v.shape[:-1] + (3, 3))


def rotvec_matrix(v: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` of rotation vectors ``(..., 3)`` (Rodrigues)."""
    angle = np.sqrt(np.sum(v * v, axis=-1))
    small = angle < 1e-12
    a = np.where(small, 1.0, angle)
    s, c = np.sin(angle)[..., None, None], (1.0 - np.cos(angle))[..., None, None]
    skew = cross_matrix(v / a[..., None])
    return np.eye(3) + s * skew + c * (skew @ skew)
