"""DOF encodings: round trips on real clips, continuity, batching, replay from anywhere."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ALL_BVH, BANDAI, CMU, ids

from adverbs import AdverbsError, read_bvh
from adverbs.motion.encoding import ROOT_COLUMNS, DofEncoding

SAMPLE = ALL_BVH[::3]


def _body(clip):
    """Joints from the body root down (joints above it are folded into the root columns)."""
    skel = clip.skeleton
    root = skel.body_root()
    return [j for j in range(skel.num_joints) if root in skel.ancestors(j)]


@pytest.mark.parametrize("kind", ["euler", "logquat"])
@pytest.mark.parametrize("path", SAMPLE, ids=ids(SAMPLE))
def test_round_trip_gives_the_same_global_positions(path, kind):
    clip = read_bvh(path)
    enc = DofEncoding.fit(clip, kind)
    dofs = enc.encode(clip)
    assert dofs.shape == (clip.num_frames, enc.num_dofs) and np.all(np.isfinite(dofs))
    back = enc.decode_clip(dofs, clip.fps, enc.start(clip))
    body = _body(clip)
    err = np.abs(back.global_positions()[:, body] - clip.global_positions()[:, body]).max()
    assert err <= 1e-6


@pytest.mark.parametrize("path", ALL_BVH, ids=ids(ALL_BVH))
def test_euler_unwrapping_leaves_no_jump_over_180_degrees(path):
    clip = read_bvh(path)
    enc = DofEncoding.fit(clip, "euler")
    angles = enc.encode(clip)[:, len(ROOT_COLUMNS) : len(ROOT_COLUMNS) + 3 * len(enc.rotated)]
    assert np.abs(np.diff(angles, axis=0)).max() < np.pi


@pytest.mark.parametrize("path", ALL_BVH, ids=ids(ALL_BVH))
def test_logquat_curves_are_continuous(path):
    clip = read_bvh(path)
    enc = DofEncoding.fit(clip, "logquat")
    rot = enc.encode(clip)[:, len(ROOT_COLUMNS) : len(ROOT_COLUMNS) + 3 * len(enc.rotated)]
    # A joint turns less than 90° in a frame of real capture; a sign flip would jump by ~2π.
    assert np.abs(np.diff(rot, axis=0)).max() < np.pi / 2


def test_decode_batch_equals_single(cmu_walk):
    enc = DofEncoding.fit(cmu_walk)
    d = enc.encode(cmu_walk)
    batch = np.stack([d, d[::-1]])
    starts = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 0.5]])
    rot, trans = enc.decode(batch, 30.0, starts)
    for k in range(2):
        r, t = enc.decode(batch[k], 30.0, starts[k])
        np.testing.assert_allclose(rot[k], r, rtol=0, atol=1e-15)
        np.testing.assert_allclose(trans[k], t, rtol=0, atol=1e-15)


def test_replay_from_another_place_and_heading_is_a_rigid_move(bandai_walk):
    enc = DofEncoding.fit(bandai_walk)
    d = enc.encode(bandai_walk)
    a = enc.decode_clip(d, bandai_walk.fps, (0.0, 0.0, 0.0)).global_positions()
    angle = 1.1
    b = enc.decode_clip(d, bandai_walk.fps, (3.0, -2.0, angle)).global_positions()
    c, s = np.cos(angle), np.sin(angle)
    rot_y = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    body = _body(bandai_walk)
    np.testing.assert_allclose(b[:, body], a[:, body] @ rot_y.T + [3.0, 0.0, -2.0], rtol=0, atol=1e-9)


def test_walk_velocity_columns_mean_what_they_say():
    clip = read_bvh(CMU / "16_15_walk.bvh")
    enc = DofEncoding.fit(clip)
    d = enc.encode(clip)
    vx, vz, turn, y = (d[:, enc.names.index(n)] for n in ROOT_COLUMNS)
    assert 0.9 < np.mean(vz) < 2.0  # walking forward, m/s, in its own frame
    assert abs(np.mean(vx)) < 0.1 and abs(np.mean(turn)) < 0.2
    assert 0.8 < np.mean(y) < 1.1  # hip height in metres
    # A right turn has a negative mean turn rate; its mirror a positive one.
    right = read_bvh(CMU / "16_19_walk_90-degree_right_turn.bvh")
    enc = DofEncoding.fit(right)
    assert enc.encode(right)[:, 2].mean() < -0.2
    assert enc.encode(right.mirror())[:, 2].mean() > 0.2


def test_one_encoding_serves_many_clips_of_a_skeleton():
    clips = [read_bvh(BANDAI / f"dataset-1_walk_{s}_001.bvh") for s in ("happy", "sad", "tired")]
    enc = DofEncoding.fit(clips, "logquat")
    for clip in clips:
        back = enc.decode_clip(enc.encode(clip), clip.fps, enc.start(clip))
        body = _body(clip)
        assert np.abs(back.global_positions()[:, body] - clip.global_positions()[:, body]).max() <= 1e-6
    with pytest.raises(AdverbsError, match="different skeleton"):
        DofEncoding.fit([clips[0], read_bvh(CMU / "16_15_walk.bvh")])
    with pytest.raises(AdverbsError, match="not on the skeleton"):
        enc.encode(read_bvh(CMU / "16_15_walk.bvh"))
    with pytest.raises(AdverbsError, match="unknown DOF encoding"):
        DofEncoding.fit(clips, "matrix")


@pytest.mark.parametrize("which", ["cmu_walk", "bandai_walk"])
def test_the_compiled_pose_decoder_is_the_numpy_one(which, request):
    """decode_pose (log-quaternion DOFs, compiled) against its NumPy reference on a real clip's DOFs, at roots all
    over the floor, and on DOFs pushed far from the clip's (rotation vectors past π, tiny ones near zero)."""
    clip = request.getfixturevalue(which)
    enc = DofEncoding.fit(clip, "logquat")
    rng = np.random.default_rng(7)
    dofs = enc.encode(clip)
    wild = dofs + rng.normal(0.0, 2.0, dofs.shape)
    wild[:5, 4:] = rng.normal(0.0, 1e-10, (5, dofs.shape[1] - 4))
    for d in (dofs, wild):
        roots = rng.uniform(-50.0, 50.0, (len(d), 3))
        rot, trans = enc.decode_pose(d, roots)
        ref_rot, ref_trans = enc._decode_pose_reference(d, roots)
        np.testing.assert_allclose(rot, ref_rot, rtol=0, atol=1e-14)
        np.testing.assert_allclose(trans, ref_trans, rtol=0, atol=1e-12)
    # Leading axes as the reference has them; one pose as a batch of one.
    rot, _ = enc.decode_pose(dofs[:6].reshape(2, 3, -1), np.zeros((2, 3, 3)))
    np.testing.assert_allclose(rot, enc._decode_pose_reference(dofs[:6], np.zeros((6, 3)))[0].reshape(rot.shape), rtol=0, atol=1e-14)
    np.testing.assert_allclose(enc.decode_pose(dofs[3], np.zeros(3))[0], rot[1, 0], rtol=0, atol=1e-14)


def test_the_compiled_root_step_is_the_numpy_one():
    """advance_root on a crowd (compiled) against the NumPy reference it mirrors, headings and speeds of all sizes."""
    from adverbs.motion.encoding import _advance_root_reference, advance_root

    rng = np.random.default_rng(8)
    root = rng.normal(0.0, [10.0, 10.0, 20.0], (500, 3))
    vel = rng.normal(0.0, [1.0, 3.0, 4.0], (500, 3))
    for dt in (1 / 30, 1 / 120, 0.7):
        np.testing.assert_allclose(advance_root(root, vel, dt), _advance_root_reference(root, vel, dt), rtol=0, atol=1e-13)
