"""Multi-robot avoidance: VelocityFilter plugins chosen by `avoidance: {type: orca | none, ...}`.

Importing the package registers the built-ins, so registration never depends on import order."""

from fleet.avoidance import none, orca  # noqa: F401  (register the built-ins)
from fleet.avoidance.clearance import StaticClearance
from fleet.avoidance.lp import solve as solve_lp
from fleet.avoidance.none import NoAvoidance
from fleet.avoidance.orca import OrcaConfig, OrcaFilter
from fleet.avoidance.registry import (
    Avoidance,
    avoidance_config,
    avoidance_configs,
    avoidance_names,
    make_avoidance,
    register_avoidance,
)
from fleet.avoidance.types import AvoidanceConfig, FleetFrame

__all__ = [
    "Avoidance", "AvoidanceConfig", "FleetFrame", "NoAvoidance", "OrcaConfig", "OrcaFilter", "StaticClearance",
    "avoidance_config", "avoidance_configs", "avoidance_names", "make_avoidance", "register_avoidance", "solve_lp",
]
