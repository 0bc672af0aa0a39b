from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from adverbs import read_bvh

DATA = Path(__file__).resolve().parent.parent / "data"
ALL_BVH = sorted(DATA.glob("*/*.bvh"))
CMU = DATA / "cmu16"
BANDAI = DATA / "bandai"
REACTIDLE = DATA / "reactidle"
# One clip of each source, for tests that need variety more than volume.
ONE_PER_SOURCE = [CMU / "16_15_walk.bvh", BANDAI / "dataset-1_walk_normal_001.bvh", REACTIDLE / "idle_002_genuine.bvh"]


def aligned(q, ref):
    """``q`` with each quaternion's sign flipped to match ``ref`` (``q`` and ``−q`` are one rotation), so that
    components can be compared with an absolute tolerance: ``1 − |q·ref|`` is quadratic in the angle."""
    return np.where(np.sum(q * ref, axis=-1, keepdims=True) < 0, -q, q)


def ids(paths):
    return [p.name for p in paths]


@pytest.fixture(scope="session")
def cmu_walk():
    return read_bvh(CMU / "16_15_walk.bvh")


@pytest.fixture(scope="session")
def bandai_walk():
    return read_bvh(BANDAI / "dataset-1_walk_normal_001.bvh")


SPECS = Path(__file__).resolve().parent.parent / "specs"
VERB_SPECS = ["cmu_walk", "bandai_styled_walk", "bandai_reach"]
# The runs are tested for their fits and adverbs (test_runs, test_fits); planting them is issue 9.
RUN_SPECS = ["cmu_run", "bandai_run"]


def on_their_feet(folder: Path, feet, others=()) -> Path:
    """Copies of shipped specs in ``folder / "specs"``, the repo's data linked beside them as their paths expect:
    ``feet`` (spec names) standing on their feet (``in_place = "feet"``, for ``in_place = true`` or after ``cyclic =
    false``), ``others`` as shipped. Returns the specs folder."""
    (folder / "data").symlink_to(DATA)
    specs = folder / "specs"
    specs.mkdir()
    for name in [*feet, *others]:
        text = (SPECS / f"{name}.toml").read_text()
        if name in feet and "\nin_place = true\n" in text:
            text = text.replace("\nin_place = true\n", '\nin_place = "feet"\n')
        elif name in feet and 'in_place = "feet"' not in text:
            text = text.replace("\ncyclic = false\n", '\ncyclic = false\nin_place = "feet"\n')
        (specs / f"{name}.toml").write_text(text)
    return specs


def _built(names):
    import warnings

    from adverbs.errors import AdverbsWarning
    from adverbs.verb.fit import build_with_examples

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)  # fits flagged as untrusted: test_fits measures them
        return {name: build_with_examples(SPECS / f"{name}.toml") for name in names}


@pytest.fixture(scope="session")
def verbs():
    """The three real verbs, built once from their specs: name → (verb, examples)."""
    return _built(VERB_SPECS)


@pytest.fixture(scope="session")
def run_verbs():
    """The two run verbs, built once from their specs: name → (verb, examples)."""
    return _built(RUN_SPECS)
