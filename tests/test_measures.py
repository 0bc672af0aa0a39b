"""Measures read the truth: real gait cycles carried along paths of known speed and turn rate.

A captured cycle is taken apart into its own straight, steady progress (a line along the chord from
its first to its last body-root position, its heading turning evenly by the cycle's turn) and what the body
does about it (sway, bob, the pelvis's yaw swing with each step). The body's part is then put back on a
path of known speed ``v`` and turn rate ``ω``: a circular arc, heading along the arc. Every frame moves
rigidly, so the clip is real motion whose true speed and turn rate are known exactly. One cycle, and a
take of several cycles one after another, must read within 1% of the truth.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import BANDAI, CMU

from adverbs import cut_steps, read_bvh
from adverbs.kinematics import quat
from adverbs.motion.heading import heading, lateral_axis
from adverbs.verb.measures import measure_all

SPECS = [{"kind": "speed"}, {"kind": "turn_rate"}, {"kind": "heading_change"}]
RATES = [0.0, 30.0, -30.0, 90.0, -90.0]  # deg/s
SPEEDS = [0.8, 1.6]  # m/s


def carried(cycle, repeats: int, speed: float, rate_deg: float):
    """``cycle`` repeated ``repeats`` times and carried along an arc at ``speed`` m/s turning ``rate_deg`` deg/s."""
    skel = cycle.skeleton
    root = skel.body_root()
    gpos, grot = cycle.forward_kinematics()
    h = np.unwrap(heading(grot[:, root], lateral_axis(skel, root)))
    f = cycle.num_frames
    u = np.arange(f) / (f - 1)
    # The cycle's own steady progress: a straight line parallel to the chord from its first body-root
    # position to its last, through the body root's mean position (so on a curve the body is on
    # average neither inside nor outside it), and a heading turning evenly by the cycle's turn.
    chord = gpos[-1, root] - gpos[0, root]
    line = gpos[:, root].mean(axis=0) + (u - 0.5)[:, None] * chord
    line[:, 1] = 0.0
    own_heading = np.arctan2(chord[0], chord[2]) + (u - 0.5) * (h[-1] - h[0])
    # Repeat (each repeat starts where the last ended: drop the shared frame).
    idx = np.concatenate([np.arange(f)] + [np.arange(1, f)] * (repeats - 1))
    n = len(idx)
    time = np.arange(n) / cycle.fps
    theta = np.deg2rad(rate_deg) * time
    if rate_deg == 0.0:
        path = np.stack([speed * time * np.sin(theta), 0 * time, speed * time * np.cos(theta)], axis=1)
    else:
        w = np.deg2rad(rate_deg)
        r = speed / w  # the arc: d/dt path = speed (sin θ, 0, cos θ)
        path = np.stack([r * (1.0 - np.cos(theta)), 0 * time, r * np.sin(theta)], axis=1)
    # Rigid move of frame i: world point y → R(φ) (y − line) + path, with φ = θ − own heading.
    phi = theta - own_heading[idx]
    rot = quat.about_y(phi)
    rotations = cycle.rotations[idx].copy()
    translations = cycle.translations[idx].copy()
    rotations[:, 0] = quat.mul(rot, rotations[:, 0])
    translations[:, 0] = quat.rotate(rot, translations[:, 0] - line[idx]) + path
    return cycle.replace(rotations=rotations, translations=translations)


@pytest.fixture(scope="module")
def cycles():
    """Real straight gait cycles of both skeletons (a curved one would carry its own curve into the truth)."""
    out = {}
    for path in [CMU / "16_15_walk.bvh", BANDAI / "dataset-1_walk_sad_001.bvh", BANDAI / "dataset-2_walk_normal_001.bvh"]:
        out[path.name] = cut_steps(read_bvh(path), "left", 1, 2)[0]
    return out


@pytest.mark.parametrize("repeats", [1, 5], ids=["one cycle", "a take of 5 cycles"])
@pytest.mark.parametrize("rate", RATES)
@pytest.mark.parametrize("speed", SPEEDS)
def test_a_clip_moved_at_known_rates_reads_them(cycles, speed, rate, repeats):
    for name, cycle in cycles.items():
        clip = carried(cycle, repeats, speed, rate)
        got_speed, got_rate, got_change = measure_all(clip, np.array([0.0, clip.duration]), SPECS)
        # Within 1% of the truth (of 30 deg/s where the turn rate is 0).
        assert abs(got_speed - speed) <= 0.01 * speed, (name, got_speed, speed)
        assert abs(got_rate - rate) <= 0.01 * max(abs(rate), 30.0), (name, got_rate, rate)
        np.testing.assert_allclose(got_change, got_rate * clip.duration, rtol=1e-12, atol=1e-9)


def test_the_old_filter_read_a_turn_low(cycles):
    """Why the heading's ends are kept: with the filter's 'nearest' padding a 90 deg/s cycle read ~0.7-0.8x."""
    from scipy.ndimage import gaussian_filter1d

    cycle = cycles["16_15_walk.bvh"]
    clip = carried(cycle, 1, 1.2, 90.0)
    skel = clip.skeleton
    root = skel.body_root()
    h = np.unwrap(heading(clip.forward_kinematics()[1][:, root], lateral_axis(skel, root)))
    flat = gaussian_filter1d(h, 0.3 * clip.fps, mode="nearest")
    old = np.rad2deg(flat[-1] - flat[0]) / clip.duration
    assert old < 0.85 * 90.0
    _, new, _ = measure_all(clip, np.array([0.0, clip.duration]), SPECS)
    assert abs(new - 90.0) <= 0.9
