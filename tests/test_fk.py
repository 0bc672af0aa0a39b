"""Forward kinematics against independent computations."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import BANDAI, CMU, REACTIDLE, ids
from scipy.spatial.transform import Rotation

from adverbs import forward_kinematics, quat, read_bvh


def test_planar_chain_matches_trigonometry():
    rng = np.random.default_rng(0)
    a, b, c = rng.uniform(-np.pi, np.pi, size=(3, 2, 5, 40))  # batch (2, 5), 40 frames
    l1, l2, l3 = 0.7, 0.4, 0.25
    parents = np.array([-1, 0, 1, 2])
    offsets = np.array([[0.3, -0.2, 0.1], [l1, 0, 0], [l2, 0, 0], [l3, 0, 0]])
    rot = np.stack([quat.from_euler("Z", x[..., None]) for x in (a, b, c, np.zeros_like(a))], axis=-2)
    gpos, grot = forward_kinematics(parents, rot, np.broadcast_to(offsets, a.shape + (4, 3)))
    assert gpos.shape == (2, 5, 40, 4, 3) and grot.shape == (2, 5, 40, 4, 4)
    base = offsets[0]
    p1 = base + l1 * np.stack([np.cos(a), np.sin(a), 0 * a], -1)
    p2 = p1 + l2 * np.stack([np.cos(a + b), np.sin(a + b), 0 * a], -1)
    p3 = p2 + l3 * np.stack([np.cos(a + b + c), np.sin(a + b + c), 0 * a], -1)
    np.testing.assert_allclose(gpos[..., 0, :], np.broadcast_to(base, gpos[..., 0, :].shape), rtol=0, atol=1e-12)
    np.testing.assert_allclose(gpos[..., 1, :], p1, rtol=0, atol=1e-12)
    np.testing.assert_allclose(gpos[..., 2, :], p2, rtol=0, atol=1e-12)
    np.testing.assert_allclose(gpos[..., 3, :], p3, rtol=0, atol=1e-12)
    # The end's global rotation is a rotation about Z by a + b + c.
    angle = Rotation.from_quat(grot[..., 3, :].reshape(-1, 4)).as_rotvec()[:, 2]
    np.testing.assert_allclose(np.cos(angle), np.cos(a + b + c).reshape(-1), rtol=0, atol=1e-12)


def test_two_joint_chain_out_of_plane():
    # Root turns 90° about Y, then the elbow bends 90° about X: the hand ends up straight below.
    parents = np.array([-1, 0, 1])
    trans = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 0.5], [0.0, 0.0, 0.3]])
    rot = np.stack([quat.from_euler("Y", [np.pi / 2]), quat.from_euler("X", [np.pi / 2]), quat.identity()])
    gpos, _ = forward_kinematics(parents, rot, trans)
    np.testing.assert_allclose(gpos[1], [0.5, 1.0, 0.0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(gpos[2], [0.5, 0.7, 0.0], rtol=0, atol=1e-12)


def _scipy_fk_from_text(path):
    """Global positions straight from the file's numbers, composing scipy Rotations frame by frame."""
    clip = read_bvh(path)
    skel = clip.skeleton
    text = path.read_text().splitlines()
    start = next(i for i, line in enumerate(text) if line.strip().upper() == "MOTION") + 3
    values = np.array([[float(v) for v in line.split()] for line in text[start:] if line.strip()])
    out = np.zeros((clip.num_frames, skel.num_joints, 3))
    for f in range(clip.num_frames):
        col = 0
        g = []
        for j in range(skel.num_joints):
            t = skel.offsets[j] / skel.unit_scale
            order, angles = "", []
            t = t.copy()
            for c in skel.channels[j]:
                if c.endswith("position"):
                    t["XYZ".index(c[0])] = values[f, col]
                else:
                    order += c[0]
                    angles.append(values[f, col])
                col += 1
            local = Rotation.from_euler(order, angles, degrees=True) if order else Rotation.identity()
            p = skel.parents[j]
            if p < 0:
                g.append(local)
                out[f, j] = t
            else:
                g.append(g[p] * local)
                out[f, j] = out[f, p] + g[p].apply(t)
    return clip, out * skel.unit_scale


REAL = [
    CMU / "16_19_walk_90-degree_right_turn.bvh",
    BANDAI / "dataset-2_walk-turn-left_normal_001.bvh",
    REACTIDLE / "idle_003_genuine.bvh",
]


@pytest.mark.parametrize("path", REAL, ids=ids(REAL))
def test_fk_matches_scipy_rotation_composition(path):
    clip, expected = _scipy_fk_from_text(path)
    assert np.abs(clip.global_positions() - expected).max() <= 1e-9


def test_batch_equals_single(cmu_walk, bandai_walk):
    clip = cmu_walk
    parents = clip.skeleton.parents
    half = clip.num_frames // 2
    rot = np.stack([clip.rotations[:half], clip.rotations[half : 2 * half]])
    trans = np.stack([clip.translations[:half], clip.translations[half : 2 * half]])
    gpos, grot = forward_kinematics(parents, rot, trans)
    for k in range(2):
        p, r = forward_kinematics(parents, rot[k], trans[k])
        assert np.array_equal(gpos[k], p) and np.array_equal(grot[k], r)
    # One frame alone equals that frame of the sequence.
    p, _ = forward_kinematics(parents, clip.rotations[7], clip.translations[7])
    assert np.array_equal(p, clip.global_positions()[7])


@pytest.mark.parametrize("path", REAL, ids=ids(REAL))
def test_the_compiled_kernel_is_the_numpy_reference(path):
    """Joint by joint, compiled, against one depth level at a time in NumPy: the same arithmetic in the same order."""
    from adverbs.kinematics.fk import forward_kinematics_reference

    clip = read_bvh(path)
    parents = clip.skeleton.parents
    fast = forward_kinematics(parents, clip.rotations, clip.translations)
    slow = forward_kinematics_reference(parents, clip.rotations, clip.translations)
    for a, b in zip(fast, slow):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)
    # Broadcasting as the reference does: one set of offsets under every frame, and leading batch axes.
    rot = clip.rotations[:12].reshape(3, 4, -1, 4)
    for a, b in zip(forward_kinematics(parents, rot, clip.translations[0]), forward_kinematics_reference(parents, rot, clip.translations[0])):
        assert a.shape == b.shape
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)


def test_a_tree_out_of_order_is_refused():
    with pytest.raises(ValueError, match="every parent before its children"):
        forward_kinematics(np.array([-1, 2, 0]), np.tile(quat.identity(), (3, 1)), np.zeros((3, 3)))


def test_forward_kinematics_to_the_feet_alone_places_them_as_the_whole_does():
    """``forward_to`` over the toes' ancestors (``fk.path_to``: what the planter and the feet's slip read) gives those
    joints the very numbers full forward kinematics does, on a real Bandai take, and writes no other joint."""
    from adverbs.kinematics._fk_kernel import forward, forward_to
    from adverbs.kinematics.fk import path_to

    clip = read_bvh(BANDAI / "dataset-1_walk_sad_001.bvh")
    parents = np.asarray(clip.skeleton.parents, dtype=np.int64)
    toes = [f.toe for f in clip.skeleton.feet()]
    path = path_to(parents, toes)
    assert set(toes) <= set(path.tolist()) and 0 not in path and len(path) < clip.skeleton.num_joints - 1
    assert all(parents[j] == 0 or parents[j] in path for j in path)
    rot, trans = np.ascontiguousarray(clip.rotations), np.ascontiguousarray(clip.translations)
    pos, grot = np.empty(trans.shape), np.empty(rot.shape)
    forward(parents, rot, trans, pos, grot)
    some_pos, some_rot = np.full(trans.shape, np.nan), np.full(rot.shape, np.nan)
    forward_to(parents, path, rot, trans, some_pos, some_rot)
    placed = np.r_[0, path]
    assert np.array_equal(some_pos[:, placed], pos[:, placed]) and np.array_equal(some_rot[:, placed], grot[:, placed])
    rest = np.setdiff1d(np.arange(clip.skeleton.num_joints), placed)
    assert np.isnan(some_pos[:, rest]).all() and np.isnan(some_rot[:, rest]).all()
