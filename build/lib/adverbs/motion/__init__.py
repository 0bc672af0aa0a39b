"""Motion: clips, the character's heading, DOF encodings (encode, decode a pose, advance the root),
foot contacts and cutting examples at contact events."""

from .clip import Clip
from .contacts import Contacts, find_contacts, foot_points
from .cutting import cut_steps, most_turning, step_events, step_range
from .encoding import ROOT_COLUMNS, DofEncoding
from .heading import character_heading, heading, lateral_axis

__all__ = [
    "ROOT_COLUMNS",
    "Clip",
    "Contacts",
    "DofEncoding",
    "character_heading",
    "cut_steps",
    "find_contacts",
    "foot_points",
    "heading",
    "lateral_axis",
    "most_turning",
    "step_events",
    "step_range",
]
