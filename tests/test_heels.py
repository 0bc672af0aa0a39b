"""A foot the hips have passed rises onto its ball where its leg cannot reach it (``FootPlanter.reach``).

Read off the frames written: while a foot is held, its ball stays put and the leg reaches it; where the
planter lifts the heel, the ankle rises about the ball (the foot pivots on its toes), not the other way;
the heel axis is across the foot.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from adverbs.feet.planter import BALL, HEEL_LIFT, FootPlanter, frame_generic
from adverbs.kinematics.fk import forward_kinematics


def _verb(verbs, run_verbs, name):
    return (verbs | run_verbs)[name][0]


@pytest.mark.parametrize("name", ["cmu_walk", "bandai_styled_walk", "cmu_run", "bandai_run"])
def test_the_heel_axis_is_across_the_foot(verbs, run_verbs, name):
    chains = _verb(verbs, run_verbs, name).leg_chains
    for axis, tip in zip(chains.heel_axis, chains.tip_offset):
        assert np.isclose(np.linalg.norm(axis), 1.0, rtol=0, atol=1e-12)
        assert abs(np.dot(axis, tip)) <= 1e-9 * np.linalg.norm(tip)  # perpendicular to the toe's offset
    # Which way it turns (the ankle up, about the toe) is read off the frames below.


@pytest.mark.parametrize("name", ["bandai_styled_walk", "cmu_walk"])
def test_a_lifted_heel_turns_the_foot_about_its_ball(verbs, run_verbs, name):
    """Held feet, frame by frame between two far examples (where the planter lifts heels), read off the frames: the
    ball stays where it was held (1 mm) while the heel lifts, and the ankle stands higher over the ball by at
    least half the lift while the hold itself keeps the foot's orientation (before its roll-off): it pivots on
    its toes."""
    verb = _verb(verbs, run_verbs, name)
    far = np.argmax(np.linalg.norm(verb.points - verb.points[0], axis=1))
    p = 0.5 * (verb.points[0] + verb.points[far])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        clip, k = verb.synthesize(p, cycles=3)
    planter = FootPlanter(verb, 1, weights=verb.weights(p)[None])
    ankles = planter.chains.end
    g = frame_generic(verb, k, np.arange(clip.num_frames) / clip.fps)
    was = np.zeros(len(planter.tips), dtype=bool)
    start_ball, start_rise = np.zeros((len(planter.tips), 3)), np.zeros(len(planter.tips))
    lifted, drift = 0, 0.0
    for f in range(clip.num_frames):
        rot, trans, _ = planter.step(clip.rotations[f][None], clip.translations[f][None], g[f : f + 1], 1.0 / clip.fps)
        gpos, _ = forward_kinematics(verb.skeleton.parents, rot, trans)
        ball, ankle = gpos[0, planter.tips], gpos[0, ankles]
        arm = ankle - ball
        rise = np.arctan2(arm[:, 1], np.hypot(arm[:, 0], arm[:, 2]))  # the ankle's elevation over the ball
        held = planter.shown_mode[0] == BALL
        new = held & ~was
        start_ball[new], start_rise[new] = ball[new], rise[new]
        drift = max(drift, float(np.max(np.hypot(*(ball - start_ball)[held][:, [0, 2]].T), initial=0.0)))
        flat = held & (planter.turn[0] == 0.0) & (planter.heel[0] > 0.05)
        assert np.all(rise[flat] >= start_rise[flat] + 0.5 * planter.heel[0][flat]), (f, rise, start_rise)
        lifted += int(flat.sum())
        was = held
        assert np.all(planter.heel[0] <= HEEL_LIFT + 1e-12)
    assert lifted > 0, "no heel was lifted before its roll-off: the case does not test the lift"
    assert drift <= 0.001, drift
