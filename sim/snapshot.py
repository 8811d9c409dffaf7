"""Exact snapshots: PyBullet state (poses, velocities, contacts), robot table, sim time, RNG state."""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import pybullet as p

from sim.errors import ErrorCode, FleetError

if TYPE_CHECKING:
    from sim.world import World


@dataclass
class WorldSnapshot:
    bullet_state: int
    step_count: int
    rng_state: dict[str, Any]
    robot_names: list[str]
    table: dict[str, np.ndarray]
    model_names: list[str]
    scans: dict[str, Any]
    contacts: dict[str, Any]
    faults: dict[Any, Any]
    extra: dict[str, Any] = field(default_factory=dict)  # room for controller state owned by upper layers


def take_snapshot(world: World) -> WorldSnapshot:
    return WorldSnapshot(
        bullet_state=p.saveState(physicsClientId=world.client),
        step_count=world.step_count,
        rng_state=copy.deepcopy(dict(world.rng.bit_generator.state)),
        robot_names=list(world.table.names),
        table=world.table.copy_state(),
        model_names=world.models.names(),
        scans=dict(world._scans),
        contacts=dict(world._contacts),
        faults=dict(world._faults),
    )


def restore_snapshot(world: World, snap: WorldSnapshot) -> None:
    """Restore exactly. Robots and models must be the same set as when the snapshot was taken."""
    if world.table.names != snap.robot_names or world.models.names() != snap.model_names:
        raise FleetError(ErrorCode.INVALID_ARGUMENT,
                         "the set of robots or models changed since this snapshot was taken",
                         f"snapshot has robots {snap.robot_names}; now {world.table.names}. "
                         "Remove/spawn to match, or reset the world")
    p.restoreState(stateId=snap.bullet_state, physicsClientId=world.client)
    world.models.invalidate()  # static bodies may be back where they were: caches of the static scene rebuild
    world.step_count = snap.step_count
    world._time = snap.step_count * world.dt
    world.rng.bit_generator.state = copy.deepcopy(snap.rng_state)
    world.table.load_state(snap.robot_names, snap.table)
    world._scans = dict(snap.scans)
    world._contacts = dict(snap.contacts)
    world._faults = dict(snap.faults)
    world.faulted = None
    # Kinematic robots live in the table; put their bodies where the table says.
    from sim.kinematic_collisions import teleport

    teleport(world, np.flatnonzero(world.table.b["kinematic"]))
