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


def test_an_anchored_encoding_stands_where_the_feet_stand():
    """An anchored encoding (``in_place = "feet"``) stores no travel: its root is the centre of the feet's stance in
    the first frame (ankles' and toes' mean, on the floor), facing as the hips face there, and the hips' sway over the
    feet is the pose's (``<body root>.tx``, ``.tz``). On the Bandai bows and guides (hips 6-11 cm over still feet):
    velocity columns all zero, the round trip exact, the compiled decoder the NumPy one, and a pose decoded from
    anywhere in the take at the take's start stands its feet where the take has them (a cut leaves no travel)."""
    clips = [read_bvh(BANDAI / f"dataset-1_{name}_001.bvh") for name in ("bow_sad", "guide_normal", "guide_sad")]
    enc = DofEncoding.fit(clips, anchored=True)
    assert enc.anchored and not DofEncoding.fit(clips).anchored
    body = enc.body_root
    col = enc.names.index(f"{enc.skeleton.names[body]}.tx")
    assert enc.names[col : col + 3] == tuple(f"{enc.skeleton.names[body]}.{a}" for a in ("tx", "ty", "tz"))
    feet = [j for f in enc.skeleton.feet() for j in (f.ankle, f.toe)]
    rng = np.random.default_rng(3)
    for clip in clips:
        dofs = enc.encode(clip)
        pos = clip.global_positions()
        np.testing.assert_array_equal(dofs[:, :3], 0.0)
        np.testing.assert_array_equal(dofs[:, col + 1], 0.0)  # ty: the height is root.y's
        start = enc.start(clip)
        np.testing.assert_allclose(start[:2], pos[0, feet][:, [0, 2]].mean(axis=0), rtol=0, atol=1e-12)
        assert np.ptp(np.linalg.norm(dofs[:, [col, col + 2]], axis=1)) > 0.03  # the hips sway 3+ cm over the feet
        back = enc.decode_clip(dofs, clip.fps, start)
        np.testing.assert_allclose(back.global_positions()[:, _body(clip)], pos[:, _body(clip)], rtol=0, atol=1e-9)
        roots = np.broadcast_to(start, (len(dofs), 3))
        rot, trans = enc.decode_pose(dofs, roots)
        ref_rot, ref_trans = enc._decode_pose_reference(dofs, roots)
        np.testing.assert_allclose(rot, ref_rot, rtol=0, atol=1e-14)
        np.testing.assert_allclose(trans, ref_trans, rtol=0, atol=1e-12)
        wild = dofs + rng.normal(0.0, 0.5, dofs.shape)
        roots = rng.uniform(-50.0, 50.0, (len(dofs), 3))
        np.testing.assert_allclose(enc.decode_pose(wild, roots)[1], enc._decode_pose_reference(wild, roots)[1],
                                   rtol=0, atol=1e-12)  # fmt: skip
        # Any frame decoded at the start stands its feet where the take has them (the take's own feet are still).
        from adverbs.kinematics.fk import forward_kinematics

        gp, _ = forward_kinematics(enc.skeleton.parents, *enc.decode_pose(dofs, np.broadcast_to(start, (len(dofs), 3))))
        drift = np.linalg.norm((gp[:, feet] - pos[:, feet])[..., [0, 2]], axis=-1).max()
        assert drift <= 1e-9, drift


def test_an_anchored_encoding_needs_feet():
    """Standing on the feet needs feet: a skeleton whose joint names show none is told so."""
    import dataclasses

    clip = read_bvh(BANDAI / "dataset-1_bow_sad_001.bvh")
    names = tuple(n.replace("Foot", "Paw").replace("Toes", "Digit") for n in clip.skeleton.names)
    pawed = clip.replace(skeleton=dataclasses.replace(clip.skeleton, names=names))
    assert not pawed.skeleton.feet() and DofEncoding.fit(pawed).num_dofs
    with pytest.raises(AdverbsError, match="no joint of this skeleton is named as a foot"):
        DofEncoding.fit(pawed, anchored=True)
