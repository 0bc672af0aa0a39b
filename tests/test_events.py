"""Keytime events from contacts on real takes: heel strikes and toe-offs in one canonical order per verb."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import BANDAI, CMU, ids

from adverbs import AdverbsError, SpecError, read_bvh
from adverbs.kinematics.skeleton import Foot
from adverbs.motion.contacts import Contacts, find_contacts
from adverbs.motion.cutting import AMBIGUOUS, NUDGE, gait_order, step_events, step_range, toe_off_lags
from adverbs.verb.examples import examples_from_spec
from adverbs.verb.spec import load_spec

CMU_WALKS = sorted(CMU.glob("16_*walk*.bvh"))
CMU_RUNS = sorted(CMU.glob("16_*run*.bvh"))
BANDAI_WALKS = sorted(BANDAI.glob("dataset-[12]_walk*.bvh"))
# dataset-1_run_normal_001 is a 24-frame loop with one heel strike per foot: no whole cycle to cut.
BANDAI_RUNS = [p for p in sorted(BANDAI.glob("dataset-[12]_run_*.bvh")) if p.name != "dataset-1_run_normal_001.bvh"]
TAKES = [(p, "walk") for p in CMU_WALKS + BANDAI_WALKS] + [(p, "run") for p in CMU_RUNS + BANDAI_RUNS]


def _cycles(contacts: Contacts) -> list[np.ndarray]:
    """Heel-strike frames of every gait cycle of the take, from either foot."""
    out = []
    for foot in ("left", "right"):
        for k in range(len(contacts.strikes(foot))):
            try:
                out.append(step_range(contacts, foot, k, 2))
            except AdverbsError:  # past the last strike, or a missed contact
                continue
    return out


def _canonical(order: str, first: str, second: str) -> list[str]:
    """The event names of one cycle from a ``first``-foot strike."""
    if order == "walk":  # strike, then the other foot's toe-off
        return [f"{first} strike", f"{second} toe-off", f"{second} strike", f"{first} toe-off", f"{first} strike"]
    return [f"{first} strike", f"{first} toe-off", f"{second} strike", f"{second} toe-off", f"{first} strike"]


@pytest.mark.parametrize(("path", "order"), TAKES, ids=ids([p for p, _ in TAKES]))
def test_every_cycle_of_every_shipped_take_has_its_events_in_order(path, order):
    contacts = find_contacts(read_bvh(path))
    cycles = _cycles(contacts)
    assert cycles, "no whole cycle in the take"
    assert gait_order([toe_off_lags(contacts, s) for s in cycles]) == order
    sides = [f.side for f in contacts.feet]
    for strikes in cycles:
        frames, names = step_events(contacts, strikes, order)
        first = contacts.feet[dict(contacts.steps())[int(strikes[0])]].side
        assert names == _canonical(order, first, sides[1 - sides.index(first)])
        assert np.all(np.diff(frames) > 0), frames
        np.testing.assert_array_equal(frames[::2], strikes)
        for t, name in zip(frames[1::2], names[1::2]):
            i = sides.index(name.split()[0])
            ends = np.array([b for _, b in contacts.intervals(i)])
            if t == round(t):  # where the foot really lifts: down the frame before, up at it
                assert contacts.planted[int(t) - 1, i] and not contacts.planted[int(t), i]
            else:  # nudged: half a frame from a strike, within a frame and a half of where the foot lifts
                assert np.min(np.abs(strikes - t)) == NUDGE
                assert np.min(np.abs(ends - t)) <= AMBIGUOUS + NUDGE


def _contacts(left: list[tuple[int, int]], right: list[tuple[int, int]], frames: int = 40) -> Contacts:
    planted = np.zeros((frames, 2), dtype=bool)
    for i, spans in enumerate((left, right)):
        for a, b in spans:
            planted[a:b, i] = True
    return Contacts((Foot("left", 0, None), Foot("right", 1, None)), planted, 30.0)


def test_a_toe_off_on_the_frame_of_the_other_foots_strike_goes_half_a_frame_to_the_orders_side():
    # Each foot lifts on the very frame the other lands: no double support, no flight.
    contacts = _contacts([(5, 15), (25, 35)], [(0, 5), (15, 25), (35, 40)])
    strikes = step_range(contacts, "left", 0, 2)
    np.testing.assert_array_equal(toe_off_lags(contacts, strikes), [0, 0, 0])
    assert gait_order([toe_off_lags(contacts, strikes)]) == "walk"  # a tie leans to the walk
    frames, names = step_events(contacts, strikes, "walk")
    np.testing.assert_array_equal(frames, [5, 5.5, 15, 15.5, 25])
    assert names == ["left strike", "right toe-off", "right strike", "left toe-off", "left strike"]
    frames, names = step_events(contacts, strikes, "run")
    np.testing.assert_array_equal(frames, [5, 14.5, 15, 24.5, 25])
    assert names == ["left strike", "left toe-off", "right strike", "right toe-off", "left strike"]
    # One frame of flight in a walk is within the ambiguity: after the strike, half a frame.
    flight = _contacts([(5, 14), (25, 35)], [(0, 4), (15, 25), (35, 40)])
    np.testing.assert_array_equal(step_events(flight, strikes, "walk")[0], [5, 5.5, 15, 15.5, 25])
    # Two frames of flight are not: a run's order, and the walk's is refused naming foot, event and frame.
    run = _contacts([(5, 13), (25, 33)], [(0, 3), (15, 23), (35, 40)])
    assert gait_order([toe_off_lags(run, strikes)]) == "run"
    np.testing.assert_array_equal(step_events(run, strikes, "run")[0], [5, 13, 15, 23, 25])
    with pytest.raises(AdverbsError, match="right toe-off after the left strike at frame 5 is missing") as info:
        step_events(run, strikes, "walk")
    assert "lifted at frame 3, 2 frames before" in str(info.value) and "flight phase" in str(info.value)


def test_a_toe_off_before_the_cut_is_found_outside_it():
    # CMU 16_29's right foot lifts a frame before the left strike that starts the cut (frame 12).
    contacts = find_contacts(read_bvh(CMU / "16_29_walk_90-degree_right_turn.bvh"))
    strikes = step_range(contacts, "left", 0, 2)
    assert strikes[0] == 12 and contacts.toe_off_before("right", 12) == 11
    frames, names = step_events(contacts, strikes, "walk")
    assert frames[1] == 12.5 and names[1] == "right toe-off"
    # CMU 16_50's right foot is in the air from the first frame to the first left strike: no walk order.
    contacts = find_contacts(read_bvh(CMU / "16_50_run_veer_right.bvh"))
    strikes = step_range(contacts, "left", 0, 2)
    assert toe_off_lags(contacts, strikes)[0] == -np.inf
    with pytest.raises(AdverbsError, match="in the air from the clip's first frame to that strike"):
        step_events(contacts, strikes, "walk")
    assert step_events(contacts, strikes, "run")[1][1] == "left toe-off"


def _spec(tmp_path, files: dict[str, str], events: str = "contacts"):
    path = tmp_path / "mixed.toml"
    path.write_text(
        f'name = "mixed"\ncut = {{ foot = "left", steps = 2, events = "{events}" }}\n'
        '[[adverbs]]\nname = "speed"\nmeasure = "speed"\n'
        + "".join(f'[[examples]]\nname = "{n}"\nfile = "{CMU / f}"\n' for n, f in files.items())
    )
    return load_spec(path)


def test_keytimes_on_the_cut_s_first_frame_stay_increasing_through_the_spec(tmp_path):
    # CMU 16_21's toe-offs all fall on the frame of the other foot's strike, the first on the cut's first frame.
    examples, _ = examples_from_spec(_spec(tmp_path, {"fast": "16_21_walk.bvh", "walk": "16_15_walk.bvh"}))
    fast = examples[0]
    assert fast.keytime_names == ("left strike", "right toe-off", "right strike", "left toe-off", "left strike")
    np.testing.assert_allclose(fast.keytimes * 30, [0, 0.5, 15, 15.5, 29], rtol=0, atol=1e-9)


def _refused_events(spec, example):
    """The SpecError refusing ``spec``, checked to name ``example`` and the field ``cut.events``."""
    with pytest.raises(SpecError) as info:
        examples_from_spec(spec)
    err = info.value
    assert err.example == example and err.field == "cut.events"
    return err


def test_a_walk_among_runs_is_named_with_its_foot_event_and_frame(tmp_path):
    runs = {"run": "16_55_run.bvh", "run veer left": "16_48_run_veer_left.bvh"}
    err = _refused_events(_spec(tmp_path, {**runs, "walk": "16_15_walk.bvh"}), "walk")
    # The walk's cut runs from the left strike at 34 to 69; its left foot stays down to frame 54, past the
    # right strike at 50 (16_15's contacts), where the runs lift theirs before the other lands.
    assert "the left toe-off before the right strike at frame 50 is missing" in err.reason
    assert "stays down until frame 54, 4 frames after" in err.reason and "no flight phase" in err.reason
    assert "'run', 'run veer left'" in err.reason and "run's order" in err.reason
    assert 'cut.events = "strikes"' in err.reason
    # A run among walks: its toe-off is before the strike.
    spec = _spec(tmp_path, {"walk": "16_15_walk.bvh", "veer": "16_13_walk_veer_right.bvh", "run": "16_55_run.bvh"})
    err = _refused_events(spec, "run")
    assert "the left toe-off after the right strike at frame 18 is missing" in err.reason
    assert "lifted at frame 15, 3 frames before" in err.reason and "'walk', 'veer'" in err.reason
    # With heel strikes only, walks and runs share a verb's keytimes.
    examples, _ = examples_from_spec(_spec(tmp_path, {**runs, "walk": "16_15_walk.bvh"}, events="strikes"))
    assert {ex.keytime_names for ex in examples} == {("left strike", "right strike", "left strike")}
