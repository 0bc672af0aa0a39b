"""Verbs: the immutable tables, building them from examples, sampling them for C creatures, whole
motions, files, specs, measured adverbs, constraints and planted feet."""

from .constraints import Constraint
from .fit import build_from_spec, build_verb
from .planting import (
    FootMetrics,
    FootPlanter,
    PlantingReport,
    foot_drift,
    measure_feet,
    plant_feet,
    plant_feet_many,
    planted_drift,
)
from .sampling import SamplingState, advance, dofs_reference, sample, sample_reference
from .spec import SpecError, load_spec
from .store import load_verb, save_verb
from .synthesis import synthesize, synthesize_dofs
from .tables import Adverb, Example, ExampleRecord, Verb

__all__ = [
    "Adverb",
    "Constraint",
    "Example",
    "ExampleRecord",
    "FootMetrics",
    "FootPlanter",
    "PlantingReport",
    "SamplingState",
    "SpecError",
    "Verb",
    "advance",
    "build_from_spec",
    "build_verb",
    "dofs_reference",
    "foot_drift",
    "load_spec",
    "load_verb",
    "measure_feet",
    "plant_feet",
    "plant_feet_many",
    "planted_drift",
    "sample",
    "sample_reference",
    "save_verb",
    "synthesize",
    "synthesize_dofs",
]
