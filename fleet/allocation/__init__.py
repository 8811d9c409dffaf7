"""Allocation of queued tasks to robots: optimal assignment in rounds (Hungarian), a sequential single-item
auction, and a greedy baseline — all aware of battery (charge stops), priorities and time windows."""

from fleet.allocation.bound import travel_lower_bound
from fleet.allocation.requests import make_request, parse_spec
from fleet.allocation.solve import SOLVERS, RobotInput, allocate, build_problem
from fleet.allocation.travel import EuclideanTravel, GridTravel
from fleet.allocation.types import (
    METHODS,
    Allocation,
    AllocationOptions,
    Assignment,
    Energy,
    Infeasible,
    Problem,
    TaskRequest,
    TaskSpec,
)

__all__ = [
    "METHODS", "SOLVERS", "Allocation", "AllocationOptions", "Assignment", "Energy", "EuclideanTravel", "GridTravel",
    "Infeasible", "Problem", "RobotInput", "TaskRequest", "TaskSpec", "allocate", "build_problem", "make_request",
    "parse_spec", "travel_lower_bound",
]
