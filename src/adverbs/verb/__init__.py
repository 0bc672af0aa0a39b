"""Verbs: the immutable tables, building them from examples, sampling them for C creatures, whole
motions, files, specs, measured adverbs and constraints (planted feet: :mod:`adverbs.feet`)."""

from .constraints import Constraint
from .fit import build_from_spec, build_verb
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
    "SamplingState",
    "SpecError",
    "Verb",
    "advance",
    "build_from_spec",
    "build_verb",
    "dofs_reference",
    "load_spec",
    "load_verb",
    "sample",
    "sample_reference",
    "save_verb",
    "synthesize",
    "synthesize_dofs",
]
