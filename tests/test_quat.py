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
