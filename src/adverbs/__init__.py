"""adverbs: verbs and adverbs — continuous, controllable motion from a few example clips.

The foundation layers: BVH in and out (:mod:`adverbs.bvh`), the skeleton (:mod:`adverbs.skeleton`),
forward kinematics (:mod:`adverbs.fk`), clips (:mod:`adverbs.clip`), DOF encodings
(:mod:`adverbs.encoding`) and foot contacts and example cutting (:mod:`adverbs.contacts`).
"""

from .bvh import format_bvh, parse_bvh, read_bvh, write_bvh
from .clip import Clip
from .errors import AdverbsError, BVHError
from .fk import forward_kinematics
from .skeleton import Skeleton

__all__ = [
    "AdverbsError",
    "BVHError",
    "Clip",
    "Skeleton",
    "format_bvh",
    "forward_kinematics",
    "parse_bvh",
    "read_bvh",
    "write_bvh",
]
__version__ = "0.1.0"
