"""Verb graphs (§5): verbs strung together by transitions, a planner, and creatures moving through them."""

from .performance import Cue, Performance, perform
from .clocks import blend_weight, duration
from .planted import plant, planter
from .player import Frame, feet, hold_phases, step
from .queue import command
from .state import GraphState, new_state
from .spec import GraphSpecError, load_graph
from .structure import CommandRefused, Graph, Transition

__all__ = [
    "CommandRefused",
    "Cue",
    "Frame",
    "Graph",
    "GraphSpecError",
    "GraphState",
    "Performance",
    "Transition",
    "blend_weight",
    "command",
    "duration",
    "feet",
    "hold_phases",
    "load_graph",
    "new_state",
    "perform",
    "plant",
    "planter",
    "step",
]
