"""Verb specs: every kind of mistake names the file, the example and the field."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from conftest import BANDAI, CMU, SPECS

from adverbs.verb.fit import build_from_spec
from adverbs.verb.measures import measure_all
from adverbs.verb.spec import SpecError, load_spec

HEAD = """
name = "test-walk"
num_cp = 10
cut = { foot = "left", steps = 2 }

[[adverbs]]
name = "turn"
measure = "turn_rate"

[[adverbs]]
name = "mood"
"""


def example(name, file, extra=""):
    return f'\n[[examples]]\nname = "{name}"\nfile = "{file}"\n{extra}\n'


def spec(tmp_path, *examples, head=HEAD):
    path = tmp_path / "walk.toml"
    path.write_text(head + "".join(examples))
    return path


def fails(path, example, field, reason):
    with pytest.raises(SpecError) as info:
        build_from_spec(path)
    err = info.value
    assert err.path == str(path) and err.example == example and err.field == field, str(err)
    assert reason in err.reason, err.reason
    assert str(path) in str(err)
    return err


WALK = CMU / "16_15_walk.bvh"
FAST = CMU / "16_21_walk.bvh"
VEER = CMU / "16_11_walk_veer_left.bvh"


def test_a_good_spec_builds(tmp_path):
    path = spec(
        tmp_path, example("a", WALK, "adverbs = { mood = 0.0 }"), example("b", FAST, "adverbs = { mood = 1.0 }")
    )
    verb = build_from_spec(path)
    assert verb.adverb_names == ("turn", "mood") and len(verb.examples) == 2


def test_missing_file(tmp_path):
    path = spec(
        tmp_path, example("a", WALK, "adverbs = { mood = 0 }"), example("b", CMU / "nope.bvh", "adverbs = { mood = 1 }")
    )
    fails(path, "b", "file", "no such file")


def test_examples_on_different_skeletons(tmp_path):
    bandai = BANDAI / "dataset-1_walk_happy_001.bvh"
    path = spec(tmp_path, example("a", WALK, "adverbs = { mood = 0 }"), example("b", bandai, "adverbs = { mood = 1 }"))
    err = fails(path, "b", "file", "different skeleton from example 'a'")
    assert err.reason.endswith("it has 22 joints, not 19"), err.reason


def test_examples_by_different_performers_name_the_bone(tmp_path):
    """A take whose shin is 2 cm longer (another performer on the same rig) is refused naming that bone."""
    text = WALK.read_text()
    other = tmp_path / "other_performer.bvh"
    other.write_text(text.replace("OFFSET 0.000000 -42.030400 0.000000", "OFFSET 0.000000 -44.030400 0.000000", 1))
    path = spec(tmp_path, example("a", WALK, "adverbs = { mood = 0 }"), example("b", other, "adverbs = { mood = 1 }"))
    err = fails(path, "b", "file", "different skeleton from example 'a'")
    assert "bone 'lfemur'→'ltibia' differs by 20.0 mm" in err.reason and "0.440 m long, not 0.420 m" in err.reason


def test_skeleton_differences_are_named():
    from adverbs.io.bvh import read_bvh

    skel = read_bvh(WALK).skeleton
    assert skel.structure_difference(read_bvh(FAST).skeleton) is None
    names = list(skel.names)
    names[3] = "left_shin"
    assert skel.structure_difference(replace(skel, names=tuple(names))) == f"joint 4 is 'left_shin', not {skel.names[3]!r}"
    channels = list(skel.channels)
    channels[2] = ("Xrotation", "Yrotation", "Zrotation")
    why = skel.structure_difference(replace(skel, channels=tuple(channels)))
    assert why.startswith(f"joint {skel.names[2]!r} has channels Xrotation Yrotation Zrotation, not ")
    parents = skel.parents.copy()
    parents[2] = 0
    why = skel.structure_difference(replace(skel, parents=parents))
    assert why == f"joint {skel.names[2]!r} hangs from {skel.names[0]!r}, not {skel.names[1]!r}"


def test_different_keytime_counts(tmp_path):
    path = spec(
        tmp_path,
        example("a", WALK, "adverbs = { mood = 0 }"),
        example("b", FAST, "adverbs = { mood = 1 }\ncut = { steps = 3 }"),
    )
    fails(path, "b", "keytimes", "has 4 keytimes")


def test_keytimes_out_of_order(tmp_path):
    path = spec(
        tmp_path,
        example("a", WALK, "adverbs = { mood = 0 }\nframes = [0, 31]\nkeytimes = [0.0, 0.6, 0.4, 1.0]"),
        example("b", FAST, "adverbs = { mood = 1 }\nframes = [0, 31]\nkeytimes = [0.0, 0.4, 0.6, 1.0]"),
    )
    fails(path, "a", "keytimes", "out of order: keytime 3")


def test_two_examples_at_the_same_point(tmp_path):
    path = spec(tmp_path, example("a", WALK, "adverbs = { mood = 0 }"), example("b", WALK, "adverbs = { mood = 0 }"))
    fails(path, "b", "adverbs", "examples 'a' and 'b' are at the same adverb point")


def test_nan_adverb_value(tmp_path):
    path = spec(tmp_path, example("a", WALK, "adverbs = { mood = 0 }"), example("b", FAST, "adverbs = { mood = nan }"))
    fails(path, "b", "adverbs.mood", "finite number")


def test_missing_adverb_value(tmp_path):
    path = spec(tmp_path, example("a", WALK, "adverbs = { mood = 0 }"), example("b", FAST))
    fails(path, "b", "adverbs.mood", "missing")


def test_measured_adverb_given_by_hand(tmp_path):
    path = spec(
        tmp_path, example("a", WALK, "adverbs = { mood = 0, turn = 3 }"), example("b", FAST, "adverbs = { mood = 1 }")
    )
    fails(path, "a", "adverbs.turn", "measured")


def test_unknown_measure(tmp_path):
    head = HEAD.replace('measure = "turn_rate"', 'measure = "happiness"')
    path = spec(
        tmp_path, example("a", WALK, "adverbs = { mood = 0 }"), example("b", FAST, "adverbs = { mood = 1 }"), head=head
    )
    fails(path, None, "adverbs.turn.measure", "unknown measure 'happiness'")


def test_measure_naming_a_missing_joint(tmp_path):
    head = HEAD.replace(
        'measure = "turn_rate"', 'measure = { kind = "joint_position", joint = "Hand_R", axis = "y", keytime = 1 }'
    )
    path = spec(
        tmp_path, example("a", WALK, "adverbs = { mood = 0 }"), example("b", FAST, "adverbs = { mood = 1 }"), head=head
    )
    fails(path, None, "adverbs.turn.measure", "joint 'Hand_R'")


def test_unknown_fields_and_bad_values(tmp_path):
    path = spec(
        tmp_path,
        example("a", WALK, "adverbs = { mood = 0 }\nmirorr = true"),
        example("b", FAST, "adverbs = { mood = 1 }"),
    )
    fails(path, "a", "mirorr", "unknown field")
    path = spec(
        tmp_path,
        example("a", WALK, "adverbs = { mood = 0 }\ncut = { strike = 9 }"),
        example("b", FAST, "adverbs = { mood = 1 }"),
    )
    fails(path, "a", "cut", "heel strike 9")
    path = spec(
        tmp_path, example("a", WALK, "adverbs = { mood = 0, style = 2 }"), example("b", FAST, "adverbs = { mood = 1 }")
    )
    fails(path, "a", "adverbs.style", "no such adverb")
    path = spec(tmp_path, head=HEAD)
    fails(path, None, "examples", "at least one")
    bare = 'name = "two-walks"\nnum_cp = 10\ncut = { foot = "left", steps = 2 }\n'
    path = spec(tmp_path, example("a", WALK), example("b", FAST), head=bare)
    fails(path, None, "adverbs", "to tell them apart")
    path = tmp_path / "broken.toml"
    path.write_text("name = [unclosed")
    fails(path, None, None, "not valid TOML")
    path = spec(
        tmp_path,
        example("a", WALK, "adverbs = { mood = 0 }"),
        example("b", VEER, "adverbs = { mood = 1 }"),
        head=HEAD.replace("num_cp = 10", 'num_cp = 10\nencoding = "matrix"'),
    )
    fails(path, None, "encoding", "unknown encoding")


def test_the_shipped_specs_parse_and_name_shipped_files():
    paths = sorted(SPECS.glob("*.toml"))
    assert {p.stem for p in paths} == {
        "cmu_walk", "cmu_run", "bandai_styled_walk", "bandai_run", "bandai_reach", "bandai_idle", "bandai_bow", "bandai_bye", "bandai_guide",
    }  # fmt: skip
    for path in paths:
        spec = load_spec(path)
        assert all((path.parent / ex["file"]).exists() for ex in spec["examples"]), path


def test_smoothing_and_spacing_mistakes(tmp_path):
    for key, value in [("smoothing", "-1"), ("smoothing", '"lots"'), ("shrinkage", "nan"), ("keytime_spacing", '"odd"'), ("timing", '"slow"'), ("timing", "1")]:
        path = spec(
            tmp_path,
            example("a", WALK, "adverbs = { mood = 0 }"),
            example("b", FAST, "adverbs = { mood = 1 }"),
            head=HEAD.replace('name = "test-walk"', f'name = "test-walk"\n{key} = {value}'),
        )
        fails(path, None, key, "must be")


def test_constraint_mistakes(tmp_path):
    head = HEAD.replace(
        'name = "test-walk"', 'name = "test-walk"\nconstraints = [{ effector = "nose", open = 0, close = 1 }]'
    )
    path = spec(
        tmp_path, example("a", WALK, "adverbs = { mood = 0 }"), example("b", FAST, "adverbs = { mood = 1 }"), head=head
    )
    fails(path, None, "constraints", "no joint named 'nose'")
    head = HEAD.replace(
        'name = "test-walk"', 'name = "test-walk"\nconstraints = [{ effector = "ltoes", open = 0, close = 7 }]'
    )
    path = spec(
        tmp_path, example("a", WALK, "adverbs = { mood = 0 }"), example("b", FAST, "adverbs = { mood = 1 }"), head=head
    )
    fails(path, None, "constraints", "keytime index 0..2")
    head = HEAD.replace('name = "test-walk"', 'name = "test-walk"\nconstraints = [{ effector = "ltoes", open = 0 }]')
    path = spec(
        tmp_path, example("a", WALK, "adverbs = { mood = 0 }"), example("b", FAST, "adverbs = { mood = 1 }"), head=head
    )
    fails(path, None, "constraints[0]", "effector, open and close")


def test_fields_of_the_wrong_type(tmp_path):
    path = tmp_path / "walk.toml"
    path.write_text(HEAD + '\n[[examples]]\nname = "a"\nfile = 5\n' + example("b", FAST, "adverbs = { mood = 1 }"))
    fails(path, "a", "file", "must be a path")
    path.write_text(
        HEAD + example("a", WALK, 'cut = "left"\nadverbs = { mood = 0 }') + example("b", FAST, "adverbs = { mood = 1 }")
    )
    fails(path, "a", "cut", "must be a table")
    head = HEAD.replace(
        'name = "test-walk"', 'name = "test-walk"\nconstraints = [{ effector = "ltoes", open = true, close = 1 }]'
    )
    path = spec(
        tmp_path, example("a", WALK, "adverbs = { mood = 0 }"), example("b", FAST, "adverbs = { mood = 1 }"), head=head
    )
    fails(path, None, "constraints", "'open' must be a keytime index")
    fails(tmp_path, None, None, "cannot read")  # a directory
    binary = tmp_path / "binary.toml"
    binary.write_bytes(b"\xff\xfe\x00name")
    fails(binary, None, None, "not a text file")


def test_a_cycle_must_end_where_it_starts(tmp_path):
    head = HEAD.replace('cut = { foot = "left", steps = 2 }', 'cut = { foot = "left", steps = 3 }')
    path = spec(
        tmp_path, example("a", WALK, "adverbs = { mood = 0 }"), example("b", FAST, "adverbs = { mood = 1 }"), head=head
    )
    fails(path, "a", "cut.steps", "even number of steps")
    head = HEAD.replace(
        'name = "test-walk"', 'name = "test-walk"\nconstraints = [{ effector = "ltoes", open = 2, close = 0 }]'
    )
    path = spec(
        tmp_path, example("a", WALK, "adverbs = { mood = 0 }"), example("b", FAST, "adverbs = { mood = 1 }"), head=head
    )
    fails(path, None, "constraints", "open at 0")


def test_examples_at_different_frame_rates(tmp_path):
    from adverbs import read_bvh, write_bvh

    fast60 = tmp_path / "fast60.bvh"
    write_bvh(read_bvh(FAST).resample(60), fast60)
    path = spec(tmp_path, example("a", WALK, "adverbs = { mood = 0 }"), example("b", fast60, "adverbs = { mood = 1 }"))
    fails(path, "b", "file", "runs at 60 fps")
    head = HEAD.replace("num_cp = 10", "num_cp = 10\nfps = 30")
    path = spec(
        tmp_path,
        example("a", WALK, "adverbs = { mood = 0 }"),
        example("b", fast60, "adverbs = { mood = 1 }"),
        head=head,
    )
    verb = build_from_spec(path)
    assert verb.fps == 30 and verb.examples[1].fit_error < 0.05


REACH_HEAD = """
name = "test-reach"
cyclic = false
num_cp = 12
{goal}

[[adverbs]]
name = "hand_y"
measure = {{ kind = "joint_position", joint = "Hand_R", axis = "y", keytime = {keytime} }}
"""


def reach_spec(tmp_path, goal, keytime=1):
    files = [BANDAI / f"dataset-2_raise-up-right-hand_{s}_001.bvh" for s in ("elderly", "youthful")]
    examples = [example(f.stem, f, 'keytimes = { peak = "Hand_R" }') for f in files]
    return spec(tmp_path, *examples, head=REACH_HEAD.format(goal=goal, keytime=keytime))


@pytest.mark.parametrize(
    "goal, keytime, field, reason",
    [
        ('goal = { chain = ["Chest", "Elbow_R"] }', 1, "goal.chain", "chain names joint 'Elbow_R', which the skeleton does not have"),
        ('goal = { chain = ["UpperLeg_R"] }', 1, "goal.chain", "chain joint 'UpperLeg_R' is not between the body root 'Hips' and the goal's joint 'Hand_R'"),
        ('goal = { chain = ["Hips", "Chest"] }', 1, "goal.chain", "chain joint 'Hips' is not between"),
        ('goal = { chain = ["Chest"] }', 0, "goal.chain", "the goal is at keytime 0"),
        ('goal = { chain = [] }', 1, "goal.chain", "must be a list of one or more joint names"),
        ('goal = { chain = "Chest" }', 1, "goal.chain", "must be a list of one or more joint names"),
        ('goal = { arm = ["Chest"] }', 1, "goal.arm", "unknown field"),
        ('goal = "Chest"', 1, "goal", "must be a table"),
    ],
)
def test_a_bad_goal_chain_is_named(tmp_path, goal, keytime, field, reason):
    fails(reach_spec(tmp_path, goal, keytime), None, field, reason)


def test_a_goal_needs_joint_position_adverbs(tmp_path):
    head = HEAD.replace('cut = { foot = "left", steps = 2 }', 'cut = { foot = "left", steps = 2 }\ngoal = { chain = ["lhumerus"] }')
    path = spec(tmp_path, example("a", WALK, "adverbs = { mood = 0 }"), example("b", FAST, "adverbs = { mood = 1 }"), head=head)
    fails(path, None, "goal.chain", "a goal chain needs adverbs measured as a joint's position")


def test_a_goal_chain_puts_the_hand_on_the_goal(tmp_path):
    # Two takes only (elderly and youthful, hands at 1.27 and 1.78 m): halfway, the plain blend misses the
    # goal; with the arm and chest as the chain, the hand is on it.
    plain = build_from_spec(reach_spec(tmp_path, ""))
    chain = build_from_spec(reach_spec(tmp_path, 'goal = { chain = ["Chest", "Shoulder_R", "UpperArm_R", "LowerArm_R"] }'))
    assert plain.goal is None and chain.goal is not None
    mid = plain.points.mean(axis=0)
    errors = []
    for verb in (plain, chain):
        clip, k = verb.synthesize(mid, fps=60.0)
        errors.append(abs(measure_all(clip, k, [verb.adverbs[0].measure])[0] - mid[0]))
    assert errors[0] > 0.01 and errors[1] <= 0.002, errors


def test_in_place_is_for_one_shots_and_keeps_the_body_where_it_stands(tmp_path):
    """``in_place`` takes an example's body root travel and turn off every frame (a stand looping into itself crept
    off its feet and turned, ``specs/bandai_idle.toml``), keeping its height and every other joint's turn; it is a
    yes or no, and only for a one-shot (a cycle's seam is taken off already)."""
    from adverbs.io.bvh import read_bvh
    from adverbs.motion.heading import heading, lateral_axis
    from adverbs.verb.examples import in_place

    path = spec(tmp_path, example("a", WALK, "adverbs = { mood = 0 }"), example("b", FAST, "adverbs = { mood = 1 }"),
                head=HEAD.replace("num_cp = 10", "num_cp = 10\nin_place = true"))  # fmt: skip
    fails(path, None, "in_place", "one-shot")
    path = spec(tmp_path, example("a", WALK, "adverbs = { mood = 0 }"), example("b", FAST, "adverbs = { mood = 1 }"),
                head=HEAD.replace("num_cp = 10", 'num_cp = 10\ncyclic = false\nin_place = "yes"'))  # fmt: skip
    fails(path, None, "in_place", 'true, false or "feet"')
    take = read_bvh(BANDAI / "dataset-1_bow_sad_001.bvh").frames(185, 221)
    kept = in_place(take)
    body = take.skeleton.body_root()
    (was, _), (pos, rot) = take.forward_kinematics(), kept.forward_kinematics()
    assert np.ptp(was[:, body, 2]) > 0.008  # the take leans 0.9 cm forward over its 1.17 s
    np.testing.assert_allclose(pos[:, body, [0, 2]] - pos[0, body, [0, 2]], 0.0, rtol=0, atol=1e-12)
    face = heading(rot[:, body], lateral_axis(take.skeleton, body))
    np.testing.assert_allclose(face - face[0], 0.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(pos[:, body, 1], was[:, body, 1], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(kept.rotations[:, 1:], take.rotations[:, 1:])
