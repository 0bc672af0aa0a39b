"""Quaternion and matrix helpers against scipy's Rotation, and identities."""

from __future__ import annotations

import numpy as np
from conftest import aligned
from scipy.spatial.transform import Rotation

from adverbs import quat
from adverbs.kinematics.floor import tilt

RNG = np.random.default_rng(9)
Q = Rotation.random(500, random_state=1).as_quat()



def test_products_and_rotation_match_scipy():
    a, b = Q[:250], Q[250:]
    np.testing.assert_allclose(
        Rotation.from_quat(quat.mul(a, b)).as_matrix(),
        (Rotation.from_quat(a) * Rotation.from_quat(b)).as_matrix(),
        rtol=0,
        atol=1e-12,
    )
    v = RNG.normal(size=(250, 3))
    np.testing.assert_allclose(quat.rotate(a, v), Rotation.from_quat(a).apply(v), rtol=0, atol=1e-12)
    np.testing.assert_allclose(quat.mul(a, quat.inv(a)), quat.identity((250,)), rtol=0, atol=1e-12)


def test_matrices_round_trip_and_match_scipy():
    m = quat.to_matrix(Q)
    np.testing.assert_allclose(m, Rotation.from_quat(Q).as_matrix(), rtol=0, atol=1e-12)
    back = quat.from_matrix(m)
    np.testing.assert_allclose(aligned(back, Q), Q, rtol=0, atol=1e-12)
    r = RNG.normal(size=(200, 3))
    np.testing.assert_allclose(quat.rotvec_matrix(r), Rotation.from_rotvec(r).as_matrix(), rtol=0, atol=1e-12)
    np.testing.assert_allclose(quat.rotvec_matrix(np.zeros(3)), np.eye(3), rtol=0, atol=1e-15)


def test_log_exp_and_slerp():
    r = RNG.normal(size=(200, 3))
    np.testing.assert_allclose(quat.log(quat.exp(r)), r, rtol=0, atol=1e-12)  # angles past π too: the sign is kept
    a, b = Q[:100], Q[100:200]
    np.testing.assert_allclose(aligned(quat.slerp(a, b, np.zeros(100)), a), a, rtol=0, atol=1e-12)
    np.testing.assert_allclose(aligned(quat.slerp(a, b, np.ones(100)), b), b, rtol=0, atol=1e-12)
    half = quat.slerp(a, b, np.full(100, 0.5))
    da = np.abs(np.sum(half * a, -1))
    db = np.abs(np.sum(half * b, -1))
    np.testing.assert_allclose(da, db, rtol=0, atol=1e-12)  # halfway: equally far from both ends
    # A quarter of the way: a quarter of the angle (where normalised lerp would not be).
    total = 2 * np.arccos(np.clip(np.abs(np.sum(a * b, -1)), 0, 1))
    quarter = quat.slerp(a, b, np.full(100, 0.25))
    np.testing.assert_allclose(
        2 * np.arccos(np.clip(np.abs(np.sum(a * quarter, -1)), 0, 1)), 0.25 * total, rtol=0, atol=1e-9
    )


def test_tilt_turns_up_onto_the_normal():
    n = RNG.normal(size=(100, 3))
    n[:, 1] = np.abs(n[:, 1]) + 0.5
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    np.testing.assert_allclose(tilt(n) @ np.array([0.0, 1.0, 0.0]), n, rtol=0, atol=1e-12)
    np.testing.assert_allclose(tilt(np.array([0.0, 1.0, 0.0])), np.eye(3), rtol=0, atol=1e-15)


def test_between_turns_one_direction_onto_another_the_short_way():
    rng = np.random.default_rng(7)
    u, v = rng.normal(size=(200, 3)), 3.0 * rng.normal(size=(200, 3))
    q = quat.between(u, v)
    unit = lambda x: x / np.linalg.norm(x, axis=-1, keepdims=True)  # noqa: E731
    np.testing.assert_allclose(quat.rotate(q, unit(u)), unit(v), rtol=0, atol=1e-12)
    # the shortest turn: its angle is the angle between the two
    angle = 2.0 * np.arccos(np.clip(q[:, 3], -1.0, 1.0))
    np.testing.assert_allclose(angle, np.arccos(np.clip(np.sum(unit(u) * unit(v), axis=1), -1, 1)), rtol=0, atol=1e-7)
    # opposite directions (one broadcast against many): a half turn, still onto v
    z = np.array([0.0, 0.0, 1.0])
    half = quat.between(z, np.array([[0.0, 0.0, -1.0], [1e-13, 0.0, -1.0], [0.0, 2.0, 0.0]]))
    np.testing.assert_allclose(quat.rotate(half, z), [[0, 0, -1], [0, 0, -1], [0, 1, 0]], rtol=0, atol=1e-12)


def _unwrap_reference(angles: np.ndarray, near: np.ndarray | None = None) -> np.ndarray:
    """The NumPy loop ``quat.unwrap_euler`` compiles (axis 0): each sample takes the branch nearest the last."""
    a = np.asarray(angles, dtype=float).copy()
    alt = np.stack([a[..., 0] + np.pi, np.pi - a[..., 1], a[..., 2] + np.pi], axis=-1)
    for i in range(0 if near is not None else 1, len(a)):
        prev = a[i - 1] if i > 0 else np.broadcast_to(np.asarray(near, dtype=float), a[0].shape)
        cands = [c + 2 * np.pi * np.round((prev - c) / (2 * np.pi)) for c in (a[i], alt[i])]
        costs = [np.sum((c - prev) ** 2, axis=-1) for c in cands]
        a[i] = np.where((costs[1] < costs[0])[..., None], cands[1], cands[0])
    return a


def test_unwrap_euler_is_its_reference_and_leaves_no_jump():
    rng = np.random.default_rng(7)
    q = quat.normalize(np.cumsum(rng.normal(scale=0.3, size=(400, 5, 4)), axis=0))  # wandering rotations
    angles = quat.to_euler("zyx", q)
    for near in (None, rng.uniform(-4, 4, size=(5, 3))):
        fast = quat.unwrap_euler("zyx", angles, near=near)
        np.testing.assert_array_equal(fast, _unwrap_reference(angles, near))
        assert np.abs(np.diff(fast, axis=0)).max() < np.pi
        np.testing.assert_allclose(quat.to_matrix(quat.from_euler("zyx", fast)), quat.to_matrix(q), rtol=0, atol=1e-9)
    # along another axis, and one sample
    np.testing.assert_array_equal(quat.unwrap_euler("zyx", angles.swapaxes(0, 1), axis=1), _unwrap_reference(angles).swapaxes(0, 1))
    assert quat.unwrap_euler("zyx", angles[:1]).shape == (1, 5, 3)


def test_the_angle_between_rotations_is_scipys_magnitude_of_the_one_between():
    """``quat.angle(a, b)``: the magnitude of ``a b⁻¹`` as scipy has it, whatever either's sign, and symmetric."""
    a, b = Q[:250], Q[250:]
    want = (Rotation.from_quat(a) * Rotation.from_quat(b).inv()).magnitude()
    np.testing.assert_allclose(quat.angle(a, b), want, rtol=0, atol=1e-7)
    np.testing.assert_allclose(quat.angle(-a, b), want, rtol=0, atol=1e-7)
    np.testing.assert_array_equal(quat.angle(a, b), quat.angle(b, a))
    assert np.all(quat.angle(a, a) < 1e-7)
