"""The run-time loop (§6): events and clocks, creatures on verb graphs in one simulation, timed scripts."""

from .events import NORMAL, OPTIONAL, SYNC, Event, EventQueue, VirtualClock, WallClock, run_events
from ..graph.easing import EASE
from .simulation import Creature, Simulation

__all__ = [
    "EASE",
    "NORMAL",
    "OPTIONAL",
    "SYNC",
    "Creature",
    "Event",
    "EventQueue",
    "Simulation",
    "VirtualClock",
    "WallClock",
    "run_events",
]
