"""Swarm behaviours as registered plugins (`type:`), run by the BehaviourManager (a ControlSource).

Importing the package registers the built-ins: flocking, coverage, formation, leader_follower, rendezvous."""

from fleet.swarm import consensus, coverage, flocking, formation, leader  # noqa: F401  (register built-ins)
from fleet.swarm.consensus import consensus_velocity
from fleet.swarm.manager import BehaviourManager, RunningBehaviour
from fleet.swarm.registry import (
    behaviour_config,
    behaviour_configs,
    behaviour_names,
    make_behaviour,
    register_behaviour,
)
from fleet.swarm.types import Behaviour, BehaviourConfig, SwarmState
from fleet.swarm.unicycle import OFFSET, to_unicycle

__all__ = [
    "OFFSET", "Behaviour", "BehaviourConfig", "BehaviourManager", "RunningBehaviour", "SwarmState",
    "behaviour_config", "behaviour_configs", "behaviour_names", "consensus_velocity", "make_behaviour",
    "register_behaviour",
    "to_unicycle",
]
