"""Foot contacts and cutting examples at heel strikes, on real walks."""

from __future__ import annotations

from itertools import pairwise

import numpy as np
import pytest
from conftest import BANDAI, CMU, REACTIDLE, ids

from adverbs import AdverbsError, read_bvh
from adverbs.motion.contacts import find_contacts, foot_points
from adverbs.motion.cutting import cut_steps, most_turning

WALKS = sorted(CMU.glob("16_*walk*.bvh")) + sorted(BANDAI.glob("dataset-*_walk*.bvh"))


@pytest.mark.parametrize("path", WALKS, ids=ids(WALKS))
def test_walk_contacts_alternate_left_and_right(path):
    clip = read_bvh(path)
    contacts = find_contacts(clip)
    assert [f.side for f in contacts.feet] == ["left", "right"]
    steps = contacts.steps()
    assert len(steps) >= 3
    feet = [f for _, f in steps]
    assert all(a != b for a, b in pairwise(feet)), feet
    # Steps of a steady walk take 0.3–0.9 s.
    gaps = np.diff([fr for fr, _ in steps]) / clip.fps
    assert np.all((gaps > 0.3) & (gaps < 0.9)), gaps
    # A planted foot is low and nearly still; a swinging one is not.
    pts = foot_points(clip, list(contacts.feet))
    heel_y = pts[:, :, 0, 1]
    planted = contacts.planted
    # Walking has no flight phase: nearly every frame has a foot down.
    assert planted.any(axis=1).mean() >= 0.9
    for i in range(2):
        assert heel_y[planted[:, i], i].mean() + 0.04 < heel_y[~planted[:, i], i].mean()


def test_idle_feet_stay_planted_on_a_floor_below_zero():
    clip = read_bvh(REACTIDLE / "idle_002_genuine.bvh")
    contacts = find_contacts(clip)
    assert contacts.planted.mean() > 0.95
    assert foot_points(clip, list(contacts.feet))[..., 1].max() < -0.5  # the floor is near y = -0.68 m


@pytest.mark.parametrize(
    "path",
    [
        CMU / "16_15_walk.bvh",
        BANDAI / "dataset-1_walk_happy_001.bvh",
        BANDAI / "dataset-2_walk-turn-left_normal_003.bvh",
    ],
    ids=["cmu", "bandai1", "bandai2"],
)
@pytest.mark.parametrize("foot", ["left", "right"])
def test_cut_starts_at_a_heel_strike_of_the_requested_foot(path, foot):
    clip = read_bvh(path)
    contacts = find_contacts(clip)
    which = contacts.foot_index(foot)
    for k in range(2):
        cut, keys = cut_steps(clip, foot, k=k, n=2, contacts=contacts)
        start = int(contacts.strikes(foot)[k])
        assert np.array_equal(cut.rotations[0], clip.rotations[start])
        # The cut starts where that foot lands: planted at the first frame, in the air the frame before.
        assert contacts.planted[start, which] and not contacts.planted[start - 1, which]
        assert keys[0] == 0 and keys[-1] == pytest.approx(cut.duration, rel=0, abs=1e-12) and np.all(np.diff(keys) > 0)
        assert len(keys) == 3
        # The middle keytime is the other foot's strike; the last is this foot's next one.
        other = 1 - which
        assert round(keys[1] * clip.fps) + start in contacts.strikes(other)
        assert round(keys[2] * clip.fps) + start == contacts.strikes(foot)[k + 1]


def test_cut_errors_say_what_is_missing(cmu_walk):
    with pytest.raises(AdverbsError, match="heel strike 9 of the left foot"):
        cut_steps(cmu_walk, "left", k=9)
    with pytest.raises(AdverbsError, match="run past"):
        cut_steps(cmu_walk, "left", k=0, n=12)
    with pytest.raises(AdverbsError, match="no 'middle' foot"):
        cut_steps(cmu_walk, "middle")
    with pytest.raises(AdverbsError, match="at least 1"):
        cut_steps(cmu_walk, "left", n=0)


def test_feet_can_be_named_by_hand(cmu_walk):
    skel = cmu_walk.skeleton
    auto = find_contacts(cmu_walk)
    manual = find_contacts(cmu_walk, feet=[skel.foot("lfoot", "ltoes"), skel.foot("rfoot", "rtoes")])
    assert np.array_equal(auto.planted, manual.planted)
    heel_only = find_contacts(cmu_walk, feet=[skel.foot("lfoot")])
    assert heel_only.planted.shape == (cmu_walk.num_frames, 1)


@pytest.mark.parametrize(
    ("name", "expected"),
    [("16_52_run_90-degree_left_turn.bvh", [22, 30, 38]), ("16_43_runandjog_90-degree_right_turn.bvh", [19, 25, 37])],
)
def test_most_turning_skips_strikes_that_do_not_alternate(name, expected):
    """A sharp turn can hide a pivoting foot's contact (it slides): two strikes of one foot in a row.
    The cycles there are skipped, not the rest of the clip."""
    clip = read_bvh(CMU / name)
    contacts = find_contacts(clip)
    left = contacts.strikes("left")
    assert not any(right in range(left[0], left[1]) for right in contacts.strikes("right"))  # L, L: no R between
    assert most_turning(clip, "left", 2, contacts).tolist() == expected
