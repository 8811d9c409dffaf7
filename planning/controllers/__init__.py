"""Tracking controllers, chosen by `type:` (mpc_casadi, mpc_osqp, pure_pursuit), the path they track, the
rotation shim that wraps them, and the navigator's recovery behaviours.

Importing the package registers the built-in controllers, so lookup never depends on import order.
"""

from planning.controllers import mpc_casadi, mpc_osqp, pure_pursuit
from planning.controllers.base import (
    Controller,
    ControllerConfig,
    RateLimiter,
    controller_names,
    make_controller,
    register_controller,
)
from planning.controllers.mpc_casadi import CasadiMpc, CasadiMpcConfig
from planning.controllers.mpc_osqp import OsqpMpc, OsqpMpcConfig
from planning.controllers.pure_pursuit import PurePursuitConfig, RegulatedPurePursuit
from planning.controllers.recovery import Recovery, RecoveryConfig
from planning.controllers.reference import PathReference, speed_profile
from planning.controllers.rotation_shim import RotationShim

__all__ = [
    "CasadiMpc",
    "CasadiMpcConfig",
    "Controller",
    "ControllerConfig",
    "OsqpMpc",
    "OsqpMpcConfig",
    "PathReference",
    "PurePursuitConfig",
    "RateLimiter",
    "Recovery",
    "RecoveryConfig",
    "RegulatedPurePursuit",
    "RotationShim",
    "controller_names",
    "make_controller",
    "mpc_casadi",
    "mpc_osqp",
    "pure_pursuit",
    "register_controller",
    "speed_profile",
]
