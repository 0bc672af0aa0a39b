"""The compiled foot planter (``feet/_planting_kernel.py``) against its NumPy reference, frame by frame.

A walk (lands on the heel) and a run (lands on the ball) of the shipped specs, each creature at its own
adverb point (at the examples, between them and 25% past them), planted over two cycles on a flat floor, a
flat floor at another level, a 10° slope and a bumpy height map; the holds given by generic time (a verb
alone) or as phase masks with some holds switched off for a while (a verb graph's path: early releases and
feet found down in mid-stance), with the examples' lifts eased in as under a decaying offset. Every state array,
every target and wanted orientation, the root drop and the planted pose must agree to 1e-9 (modes and flags
exactly), for a crowd in one planter and for one creature.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from adverbs.apps.evaluate import obedience_points
from adverbs.kinematics import quat
from adverbs.kinematics.fk import forward_kinematics
from adverbs.kinematics.floor import FlatFloor, HeightMapFloor, SlopeFloor
from adverbs.feet.planter import BALL, FREE, HEEL, FootPlanter, example_lifts, frame_generic, hold_modes, swing_lifts

TOL = 1e-9
_x = np.arange(-40.0, 40.01, 0.5)
BUMPS = HeightMapFloor(0.04 * np.sin(0.9 * _x)[:, None] * np.cos(0.7 * _x)[None, :] + 0.02, 0.5, (-40.0, -40.0))
FLOORS = {"flat": FlatFloor(0.0), "level 0.3": FlatFloor(0.3), "slope 10°": SlopeFloor(10.0), "height map": BUMPS}
VERBS = ["cmu_walk", "cmu_run"]
EXACT = ("mode", "spent", "settle", "started")
CLOSE = ("turn", "target", "held_rot", "offset", "offset_vel", "since", "drop", "rising", "rel_vec", "rot_since",
         "hover", "ground", "prev_free", "heel", "kept")  # fmt: skip


def _motions(verb):
    """Two cycles at a sample of every kind of obedience point: per frame ``(C, J, ·)`` poses, generic times
    ``(F, C)``, and the points ``(C, A)``."""
    pts = np.concatenate([v[:: max(1, len(v) // 3)] for v in obedience_points(verb).values()])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # extrapolation warnings at 25% past
        motions = [verb.synthesize(p, cycles=2) for p in pts]
    n = min(clip.num_frames for clip, _ in motions)
    rot = np.stack([clip.rotations[:n] for clip, _ in motions], axis=1)
    trans = np.stack([clip.translations[:n] for clip, _ in motions], axis=1)
    g = np.stack([frame_generic(verb, k, np.arange(n) / clip.fps) for clip, k in motions], axis=1)
    return rot, trans, g, pts


def _phases(planter, weights, g, f):
    """The holds at generic times ``g (C,)`` as masks, with each creature's holds switched off for 5 frames of
    every 40 (at different frames for each creature and leg), the swings' least lifts, the examples' lifts 3 cm over
    their own (so they hold the foot up), and their share under a decaying offset: rising from 0 to 1 over 24
    frames of every 40 (at different frames for each creature), then all of it."""
    inside, turn = hold_modes(planter.verb.cyclic, g[:, None], planter.opens, planter.times)
    swing = swing_lifts(planter.verb.cyclic, g[:, None], planter.opens, planter.times)
    c, legs = np.meshgrid(np.arange(inside.shape[0]), np.arange(inside.shape[1]), indexing="ij")
    examples = example_lifts(planter.verb, weights, g) + 0.03
    eased = np.minimum(((f + 11 * np.arange(len(g))) % 40) / 24.0, 1.0)
    return inside & ((f + 7 * c + 13 * legs) % 40 >= 5), turn, swing, examples, eased


def _assert_same_state(compiled, reference, what):
    for name in EXACT:
        assert np.array_equal(getattr(compiled, name), getattr(reference, name)), (what, name)
    for name in CLOSE:
        a, b = getattr(compiled, name), getattr(reference, name)
        assert np.array_equal(np.isfinite(a), np.isfinite(b)), (what, name)
        np.testing.assert_allclose(a[np.isfinite(b)], b[np.isfinite(b)], rtol=0, atol=TOL, err_msg=f"{what}: {name}")


def _close(a, b, what):
    np.testing.assert_allclose(a, b, rtol=0, atol=TOL, err_msg=what)


@pytest.fixture(scope="module")
def motions(verbs, run_verbs):
    return {name: (verb, *_motions(verb)) for name, verb in ((n, {**verbs, **run_verbs}[n][0]) for n in VERBS)}


@pytest.mark.parametrize("source", ["generic", "phases"])
@pytest.mark.parametrize("floor", FLOORS)
@pytest.mark.parametrize("name", VERBS)
def test_compiled_planter_is_the_reference(motions, name, floor, source):
    verb, rot, trans, g, pts = motions[name]
    dt = 1.0 / verb.fps
    weights = verb.weights(pts)
    # A crowd through targets() and reach() (plant_feet_many's path), the crowd and one creature through step().
    made = {
        key: [FootPlanter(verb, len(w), FLOORS[floor], w, compiled=compiled) for compiled in (True, False)]
        for key, w in (("targets", weights), ("step", weights), ("one", weights[-1:]))
    }  # fmt: skip
    assert all(a._compiled is not None and b._compiled is None for a, b in made.values())
    tips, ends, upper = made["step"][0].tips, verb.leg_chains.end, verb.leg_chains.upper
    seen = set()
    for f in range(len(g)):
        phases = _phases(made["step"][1], weights, g[f], f) if source == "phases" else None
        generic = None if phases else g[f]
        gpos, grot = forward_kinematics(verb.skeleton.parents, rot[f], trans[f])
        free_pos, free_rot = gpos[:, tips], quat.to_matrix(grot[:, ends])
        out = [p.targets(free_pos, free_rot, generic, dt, phases) for p in made["targets"]]
        for (a, b), what in zip(zip(*out), ("targets", "wanted")):
            _close(a, b, f"frame {f}: {what}")
        rise = np.full(len(pts), 0.01 * np.sin(f))  # reach on its own: any rise will do
        reached = [p.reach(gpos[:, upper], rise, *out[1], dt) for p in made["targets"]]
        for (a, b), what in zip(zip(*reached), ("reached targets", "reached wanted", "drop")):
            _close(a, b, f"frame {f}: {what}")
        for key in ("step", "one"):
            n = len(made[key][0].mode)
            sel = slice(len(pts) - n, None)
            frame = (rot[f, sel], trans[f, sel], None if phases else g[f, sel], dt)
            ph = None if phases is None else tuple(x[sel] for x in phases)
            (ra, ta, ia), (rb, tb, ib) = (p.step(*frame, ph) for p in made[key])
            _close(ta, tb, f"frame {f}: {key}: translations")
            _close(ra * np.sign(np.sum(ra * rb, axis=-1, keepdims=True)), rb, f"frame {f}: {key}: rotations")
            _close(ia.root_drop, ib.root_drop, f"frame {f}: {key}: root drop")
            _close(ia.residual, ib.residual, f"frame {f}: {key}: residual")
        for key, (a, b) in made.items():
            _assert_same_state(a, b, f"frame {f}: {key}")
        seen.update(np.unique(made["step"][1].mode).tolist())
    # Every mode was visited (a walk lands on its heels; a run on its balls, but at some points on its heels too).
    assert seen == {FREE, HEEL, BALL} if name == "cmu_walk" else {FREE, BALL} <= seen, seen
