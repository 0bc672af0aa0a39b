"""adverbs: verbs and adverbs — continuous, controllable motion from a few example clips.

The package is cut in layers, each a subpackage that imports only from the ones below it:

| layer | holds |
| --- | --- |
| :mod:`adverbs.compiled` | numba's cache of the compiled kernels, dropped when any kernel file changes |
| :mod:`adverbs.interp` | B-splines, keytime warping, linear + radial interpolation (pure numerics) |
| :mod:`adverbs.kinematics` | quaternions, skeletons, forward kinematics, two-bone IK, floors |
| :mod:`adverbs.motion` | clips, heading, DOF encodings, foot contacts, cutting examples |
| :mod:`adverbs.io` | BVH read and write |
| :mod:`adverbs.verb` | a verb's tables, building, sampling, synthesis, files, specs, measures, constraints |
| :mod:`adverbs.feet` | planted feet: the foot planter (state per creature, its compiled loop), offline planting, measures |
| :mod:`adverbs.graph` | verb graphs: specs, transitions, the planner, creatures stepping through them |
| :mod:`adverbs.runtime` | the event loop and clocks, the frame as one compiled pass, simulations, timed scripts |
| :mod:`adverbs.dataset` | motion datasets: clips over adverb spaces and scripts, on Dask, sharded, a Parquet manifest |
| :mod:`adverbs.apps` | the command line and evaluation |

What most users need is re-exported here, so ``import adverbs`` is enough.
"""

from . import compiled  # noqa: F401  (first: it refreshes numba's cache of the kernels before any is imported)
from .errors import AdverbsError, BVHError
from .feet import FootPlanter, foot_drift, measure_feet, plant_feet, plant_feet_many
from .interp import AdverbInterpolator
from .graph import CommandRefused, Cue, Graph, GraphSpecError, load_graph, perform
from .io import format_bvh, parse_bvh, portable, read_bvh, read_glb, read_motion, write_bvh, write_glb, write_motion
from .kinematics import FlatFloor, HeightMapFloor, LegChains, Skeleton, SlopeFloor, forward_kinematics, ik, quat
from .motion import Clip, DofEncoding, cut_steps, find_contacts
from .runtime import Creature, Simulation
from .verb import (
    Adverb,
    Constraint,
    Example,
    SamplingState,
    SpecError,
    Verb,
    advance,
    build_from_spec,
    build_verb,
    load_spec,
    load_verb,
    sample,
    save_verb,
    synthesize,
)

__all__ = [
    "Adverb",
    "AdverbInterpolator",
    "AdverbsError",
    "BVHError",
    "Clip",
    "CommandRefused",
    "DatasetSpecError",
    "Creature",
    "Cue",
    "Constraint",
    "DofEncoding",
    "Example",
    "FlatFloor",
    "FootPlanter",
    "Graph",
    "MotionDataset",
    "GraphSpecError",
    "HeightMapFloor",
    "LegChains",
    "SamplingState",
    "Simulation",
    "Skeleton",
    "SlopeFloor",
    "SpecError",
    "Verb",
    "advance",
    "build_from_spec",
    "build_verb",
    "cut_steps",
    "dataset",
    "find_contacts",
    "foot_drift",
    "format_bvh",
    "forward_kinematics",
    "ik",
    "load_dataset",
    "load_graph",
    "load_spec",
    "load_verb",
    "measure_feet",
    "parse_bvh",
    "perform",
    "plant_feet",
    "plant_feet_many",
    "portable",
    "quat",
    "read_bvh",
    "read_glb",
    "read_motion",
    "sample",
    "save_verb",
    "synthesize",
    "write_bvh",
    "write_glb",
    "write_motion",
]
__version__ = "0.1.0"
_DATASET = ("dataset", "load_dataset", "MotionDataset", "DatasetSpecError")


def __getattr__(name: str):
    """The dataset layer, imported when first asked for (it brings pyarrow and scipy.stats, which nothing else needs):
    ``adverbs.dataset`` is its subpackage, callable (``adverbs.dataset(SPEC, OUT)`` makes a dataset)."""
    if name in _DATASET:
        import importlib

        package = importlib.import_module(".dataset", __name__)
        return package if name == "dataset" else getattr(package, name)
    raise AttributeError(f"module 'adverbs' has no attribute {name!r}")
