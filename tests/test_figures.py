"""``adverbs figure``: pictures of a verb's adverb space for the shipped verbs."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from adverbs.apps.figures import EXAMPLE_COLOR, GRID_COLOR, _grid, _poses, figure
from adverbs.errors import AdverbsError

AXES = {"cmu_walk": ("speed", "turn"), "bandai_styled_walk": ("valence", "energy"), "bandai_reach": ("hand_z", "hand_y")}


def _has(pixels: np.ndarray, color: str) -> int:
    rgb = np.array([int(color[i : i + 2], 16) for i in (1, 3, 5)])
    return int((np.abs(pixels[..., :3].astype(int) - rgb).max(axis=-1) < 40).sum())


@pytest.mark.parametrize("name", list(AXES))
def test_figures_of_the_shipped_verbs(verbs, name, tmp_path):
    verb, _ = verbs[name]
    for kind in ("poses", "space"):
        out = figure(verb, AXES[name], tmp_path / f"{name}_{kind}.png", kind=kind)
        pixels = np.asarray(Image.open(out).convert("RGB"))
        assert pixels.std() > 10
        if kind == "poses":  # the grid's poses and the examples', each in its colour
            assert _has(pixels, GRID_COLOR) > 500 and _has(pixels, EXAMPLE_COLOR) > 100


def test_the_pose_grid_is_the_verb_at_its_points(verbs):
    # At the examples the poses drawn are the examples' own: the reach's hand at the peak is each example's goal.
    verb, _ = verbs["bandai_reach"]
    hand = verb.skeleton.index("Hand_R")
    pos = _poses(verb, verb.points)
    np.testing.assert_allclose(pos[:, hand, 1], verb.points[:, 1], rtol=0, atol=0.005)
    points, a, b = _grid(verb, 2, 1, 4)
    assert points.shape == (16, 3) and a[0] == verb.points[:, 2].min() and b[-1] == verb.points[:, 1].max()
    np.testing.assert_allclose(points[:, 0], verb.points[:, 0].mean())


def test_figure_mistakes_are_named(verbs, tmp_path):
    verb, _ = verbs["cmu_walk"]
    with pytest.raises(AdverbsError, match="no adverb 'mood'"):
        figure(verb, ("speed", "mood"), tmp_path / "x.png")
    with pytest.raises(AdverbsError, match="two different adverbs"):
        figure(verb, ("speed", "speed"), tmp_path / "x.png")
    with pytest.raises(AdverbsError, match="--kind 'walk'"):
        figure(verb, ("speed", "turn"), tmp_path / "x.png", kind="walk")
    with pytest.raises(AdverbsError, match="--example 99"):
        figure(verb, ("speed", "turn"), tmp_path / "x.png", kind="space", example=99)
    assert not (tmp_path / "x.png").exists()


def test_the_feet_figure_draws_planted_and_free_toes(verbs, tmp_path):
    verb, _ = verbs["cmu_walk"]
    out = figure(verb, None, tmp_path / "feet.png", kind="feet")
    pixels = np.asarray(Image.open(out).convert("RGB"))
    assert pixels.std() > 10
    assert _has(pixels, "#1f77b4") > 300 and _has(pixels, "#ff7f0e") > 300  # one colour per toe: both feet drawn
    # Two adverbs: they are the axes. Three (the reach): say which two.
    assert figure(verb, None, tmp_path / "grid.png", n=2).exists()
    with pytest.raises(AdverbsError, match="--kind poses needs --axes A B: two of hand_x, hand_y, hand_z"):
        figure(verbs["bandai_reach"][0], None, tmp_path / "x.png")
    assert not (tmp_path / "x.png").exists()
