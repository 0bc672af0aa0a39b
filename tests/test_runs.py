"""The shipped run verbs: built from their specs, toe-offs as keytimes in a run's order, exact at the examples,
adverbs obeyed at, between and past them (those two in test_verb, over every shipped verb)."""

from __future__ import annotations

import numpy as np
import pytest

from adverbs.verb.constraints import Constraint

RUN_ORDER = ("left strike", "left toe-off", "right strike", "right toe-off", "left strike")


@pytest.fixture(scope="module")
def runs(run_verbs):
    return run_verbs


def test_the_run_verbs_are_what_their_specs_say(runs):
    cmu, cmu_examples = runs["cmu_run"]
    assert cmu.adverb_names == ("speed", "turn") and len(cmu.examples) >= 12 and cmu.cyclic
    # They span 2.0–4.3 m/s and 200 deg/s of turning, from 90° turns left to right.
    assert np.ptp(cmu.points[:, 0]) > 2.0 and cmu.points[:, 1].min() < -80 and cmu.points[:, 1].max() > 110
    # Cycles as short as 15 frames (16 with both ends), and fewer control points than that.
    assert min(ex.clip.num_frames for ex in cmu_examples) == 16 and cmu.num_cp < 16
    bandai, _ = runs["bandai_run"]
    assert bandai.adverb_names == ("valence", "energy", "speed") and len(bandai.examples) == 9
    assert np.ptp(bandai.points[:, 2]) > 2.0  # the tired run at 1.7 m/s, the fastest normal one at 3.9
    for verb, skel_toes in ((cmu, ("ltoes", "rtoes")), (bandai, ("Toes_L", "Toes_R"))):
        # Every foot lifts before the other lands, and is held from its strike to its own toe-off.
        assert verb.keytime_names == RUN_ORDER
        assert verb.constraints == (Constraint(skel_toes[0], 0, 1), Constraint(skel_toes[1], 2, 3))
        assert np.all(np.diff(verb.keytimes_table, axis=1) > 0)
