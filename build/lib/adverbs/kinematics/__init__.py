"""Kinematics: quaternion arrays, skeletons, forward kinematics, two-bone IK and floors.

Below everything that moves: these know joints and rotations, not motions or verbs.
"""

from . import ik, quat
from .fk import bone_lengths, forward_kinematics
from .floor import FlatFloor, Floor, FunctionFloor, HeightMapFloor, SlopeFloor, parse_floor
from .ik import IKResult, LegChains
from .skeleton import Foot, Skeleton

__all__ = [
    "FlatFloor",
    "Floor",
    "Foot",
    "FunctionFloor",
    "HeightMapFloor",
    "IKResult",
    "LegChains",
    "Skeleton",
    "SlopeFloor",
    "bone_lengths",
    "forward_kinematics",
    "ik",
    "parse_floor",
    "quat",
]
