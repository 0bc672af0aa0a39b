"""Planted feet (§3.3): the foot planter that enforces a verb's constraints one frame at a time for C creatures
(:mod:`.planter`, its compiled loop :mod:`._planting_kernel`), whole clips planted offline (:mod:`.offline`), and
what the feet did, measured on the frames written (:mod:`.measures`).

A layer of its own between :mod:`adverbs.verb` (a verb's tables, its constraints and their holds among them: data)
and :mod:`adverbs.graph` (verbs played through transitions, whose feet this planter keeps).
"""

from .measures import FootMetrics, foot_drift, measure_feet, planted_drift
from .offline import PlantingReport, plant_feet, plant_feet_many
from .planter import FootPlanter

__all__ = [
    "FootMetrics",
    "FootPlanter",
    "PlantingReport",
    "foot_drift",
    "measure_feet",
    "plant_feet",
    "plant_feet_many",
    "planted_drift",
]
