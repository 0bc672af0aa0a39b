"""Verb graphs (§5): verbs strung together by transitions, a planner, and creatures moving through them."""

from .player import Frame, GraphState, blend_weight, command, duration, feet, hold_phases, new_state, step
from .spec import GraphSpecError, load_graph
from .structure import CommandRefused, Graph, Transition

__all__ = [
    "CommandRefused",
    "Frame",
    "Graph",
    "GraphSpecError",
    "GraphState",
    "Transition",
    "blend_weight",
    "command",
    "duration",
    "feet",
    "hold_phases",
    "load_graph",
    "new_state",
    "step",
]
