"""Collision-avoidance prototyping (DESIGN §4 "Two moving bodies", "Certified clearance",
"Repair"): repair of a colliding rational motion, two moving bodies, and the tools the
repair study uses (seeded colliding cases, the sampling-based comparator)."""

from .baseline import SampledRepair, sampled_repair
from .cases import AvoidCase, colliding_cases
from .pair import PairError, certify_pair, pair_distances
from .repair import Moved, Repair, RepairError, repair

__all__ = [
    "AvoidCase",
    "Moved",
    "PairError",
    "Repair",
    "RepairError",
    "SampledRepair",
    "certify_pair",
    "colliding_cases",
    "pair_distances",
    "repair",
    "sampled_repair",
]
