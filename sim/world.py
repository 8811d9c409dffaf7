"""The one owner of the PyBullet world: fixed physics step, sim-time clock, one seeded RNG.

Every PyBullet call passes this world's client id. See docs/world-api.md for the API tour.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pybullet as p
from numpy.typing import ArrayLike

from sim import world_models, world_motion, world_sensors
from sim.drive import limit_twist
from sim.errors import ErrorCode, FleetError, unknown_name
from sim.kinematic_collisions import RawContact
from sim.models import ModelRegistry
from sim.ray_backends import RayBackends, cast_pybullet
from sim.raycast_layout import RayLayout
from sim.robot_body import RobotBody
from sim.robot_spec import RobotSpec, default_robot_path, load_robot_spec
from sim.robot_table import RobotTable
from sim.sensors.inertial import imu_reading, odometry_reading
from sim.sensors.lidar import LidarConfig
from sim.snapshot import restore_snapshot, take_snapshot
from sim.types import CameraImage, Contact, ContactReading, Fidelity, ImuReading, LidarScan, OdometryReading, Pose2D
from sim.world_types import CommandResult, ModelState, SensorFault

LIDAR_PHASES = ("spread", "aligned")
Reading = LidarScan | ImuReading | OdometryReading | ContactReading


class World:
    """A PyBullet world with robots, sensors and a sim-time clock. Not thread-safe: one owner steps it."""

    def __init__(self, *, physics_hz: float = 100.0, seed: int = 0, gui: bool = False,
                 fidelity: Fidelity = "kinematic", gravity: tuple[float, float, float] = (0.0, 0.0, -9.81),
                 ground: bool = True, name: str = "world", raycast: str = "embree",
                 lidar_phases: str = "spread") -> None:
        if not (1.0 <= physics_hz <= 10_000.0):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"physics_hz must be in [1, 10000], got {physics_hz}")
        if fidelity not in ("kinematic", "dynamic"):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unknown fidelity '{fidelity}'",
                             "use 'kinematic' or 'dynamic'")
        if lidar_phases not in LIDAR_PHASES:
            raise unknown_name("lidar phase policy", lidar_phases, LIDAR_PHASES, ErrorCode.INVALID_ARGUMENT)
        self.name = name
        # "spread": robots' lidars are cast in different physics steps of their period, so no one step casts the
        # whole fleet's (sim/robot_spawn.py lidar_phase); "aligned": every first scan one period after spawn.
        self.lidar_phases = lidar_phases
        self.rays = RayBackends(self, raycast)
        self.client = p.connect(p.GUI if gui else p.DIRECT)
        self.physics_hz = float(physics_hz)
        self.dt = 1.0 / self.physics_hz
        self.seed = seed
        self.rng = np.random.default_rng(seed)
        self.fidelity: Fidelity = fidelity
        self.step_count = 0
        self._time = 0.0
        self.faulted: FleetError | None = None
        # Contacts of dynamic robots are sampled at ≤ 50 Hz (the bumper rate): a global contact query each
        # physics step would cost a quarter of a 100-robot step.
        self._contact_every = max(1, round(self.physics_hz / 50.0))
        p.setTimeStep(self.dt, physicsClientId=self.client)
        p.setGravity(*gravity, physicsClientId=self.client)
        p.setPhysicsEngineParameter(deterministicOverlappingPairs=1, physicsClientId=self.client)
        self.table = RobotTable()
        self.specs: dict[str, RobotSpec] = {}
        self.bodies: dict[str, RobotBody] = {}
        self.fidelities: dict[str, Fidelity] = {}
        self._lidar_cfg: list[LidarConfig] = []
        self._scans: dict[str, LidarScan] = {}
        self._contacts: dict[str, tuple[RawContact, ...]] = {}  # (other uid, position, depth or force)
        self._faults: dict[tuple[str, str], SensorFault] = {}
        self._listeners: list[tuple[frozenset[str], Callable[[Reading], None]]] = []
        self.models = ModelRegistry(self.client)
        self.label_of: dict[int, tuple[str, dict[int, str]]] = {}
        self._default_spec: RobotSpec | None = None
        if ground:
            self.models.add_ground_plane()
        self._sync_labels()

    # ---- clock -----------------------------------------------------------------------------------

    @property
    def time(self) -> float:
        return self._time

    def step(self, n: int = 1) -> None:
        """Advance n fixed physics steps. Each step reads like a recipe."""
        if n < 0:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"cannot step {n} times")
        for _ in range(n):
            self._refuse_if_faulted()
            self._limit_twists()  # acceleration limits, both drive models
            self._drive_dynamic_robots()  # wheel motor targets from the limited twist
            self._step_physics()  # PyBullet only when something is dynamic
            self._move_kinematic_robots()  # unicycle integration, teleport, collisions resolved
            self._read_dynamic_robots()  # pose, twist, wheel angles back from PyBullet
            self._advance_clock()
            self._sample_sensors()  # due lidars in one batched ray cast, IMU, odometry, contacts
            self._check_physics_health()

    def run_for(self, seconds: float) -> None:
        """Step as fast as possible until sim time has advanced by `seconds` (rounded to whole steps)."""
        if not math.isfinite(seconds) or seconds < 0:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"seconds must be finite and ≥ 0, got {seconds}")
        self.step(round(seconds * self.physics_hz))

    def _advance_clock(self) -> None:
        self.step_count += 1
        self._time = self.step_count * self.dt  # no accumulated float error

    def _refuse_if_faulted(self) -> None:
        if self.faulted is not None:
            raise FleetError(ErrorCode.PHYSICS_UNSTABLE, f"world is halted: {self.faulted.message}",
                             "restore a snapshot or reset the world")

    # ---- robots ----------------------------------------------------------------------------------

    def default_spec(self) -> RobotSpec:
        if self._default_spec is None:
            self._default_spec = load_robot_spec(default_robot_path())
        return self._default_spec

    def spawn_robot(self, name: str, pose: Pose2D, spec: RobotSpec | None = None,
                    fidelity: Fidelity | None = None, *, check_collision: bool = True) -> str:
        from sim.robot_spawn import spawn_robot

        return spawn_robot(self, name, pose, spec or self.default_spec(), fidelity or self.fidelity,
                           check_collision=check_collision)

    def remove_robot(self, name: str) -> None:
        self._row(name)
        body = self.bodies.pop(name)
        p.removeBody(body.uid, physicsClientId=self.client)
        self.table.remove(name)
        del self.specs[name], self.fidelities[name]
        self._lidar_cfg = [self._lidar_cfg_for(n) for n in self.table.names]
        self._scans.pop(name, None)
        self._contacts.pop(name, None)
        self._sync_labels()

    def _lidar_cfg_for(self, name: str) -> LidarConfig:
        return LidarConfig.from_spec(self.specs[name])

    def robot_names(self) -> list[str]:
        return list(self.table.names)

    def _row(self, name: str) -> int:
        if not self.table.has(name):
            raise unknown_name("robot", name, self.table.names, ErrorCode.UNKNOWN_ROBOT)
        return self.table.index(name)

    def robot_spec(self, name: str) -> RobotSpec:
        self._row(name)
        return self.specs[name]

    def robot_fidelity(self, name: str) -> Fidelity:
        self._row(name)
        return self.fidelities[name]

    def robot_pose(self, name: str) -> Pose2D:
        i, f = self._row(name), self.table.f
        return Pose2D(float(f["x"][i]), float(f["y"][i]), float(f["yaw"][i]))

    def robot_twist(self, name: str) -> tuple[float, float]:
        i, f = self._row(name), self.table.f
        return float(f["v"][i]), float(f["w"][i])

    def robot_in_collision(self, name: str) -> bool:
        return bool(self.table.b["in_collision"][self._row(name)])

    def set_cmd_vel(self, name: str, v: float, w: float) -> CommandResult:
        """Command a body twist; it is clamped to the robot's velocity limits (and then rate-limited by its
        acceleration limits as it is applied). The result says what was applied and why."""
        # the hot call of every driver: one dict lookup (an unknown name raises UNKNOWN_ROBOT in _row)
        i = self.table._index.get(name)
        if i is None:
            i = self._row(name)
        if not (math.isfinite(v) and math.isfinite(w)):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"velocity must be finite, got v={v}, w={w}")
        f = self.table.f
        max_v, max_w = f["max_v"].item(i), f["max_w"].item(i)
        av, aw = max(-max_v, min(max_v, v)), max(-max_w, min(max_w, w))
        f["cmd_v"][i], f["cmd_w"][i] = av, aw
        if av == v and aw == w:
            return CommandResult(name, v, w, av, aw, False, "", self._time)
        reasons = []
        if av != v:
            reasons.append(f"linear {v:.3g} clamped to ±{max_v:.3g} m/s")
        if aw != w:
            reasons.append(f"angular {w:.3g} clamped to ±{max_w:.3g} rad/s")
        return CommandResult(name, v, w, av, aw, True, "; ".join(reasons), self._time)

    def set_cmd_vels(self, robots: Sequence[str] | np.ndarray, v: ArrayLike, w: ArrayLike) -> np.ndarray:
        """set_cmd_vel for many robots in one call (names, or rows of robot_names() as an integer array; one
        v and w each, or one for all). Returns which commands were clamped; a bad entry changes nothing."""
        return world_motion.set_cmd_vels(self, robots, v, w)

    def emergency_stop(self, name: str) -> None:
        """Brake now, bypassing the acceleration ramp: the command and the drive setpoint drop to zero
        (a kinematic robot halts this step; a dynamic one's wheel motors brake with their full torque)."""
        i, f = self._row(name), self.table.f
        for col in ("cmd_v", "cmd_w", "sp_v", "sp_w"):
            f[col][i] = 0.0

    def set_robot_pose(self, name: str, pose: Pose2D, *, check_collision: bool = True) -> None:
        """Teleport a robot (ground truth); its odometry keeps its own drifting estimate."""
        from sim.robot_spawn import place_robot

        place_robot(self, self._row(name), pose, check_collision=check_collision)

    # ---- per-step internals --------------------------------------------------------------------------

    def _limit_twists(self) -> None:
        if len(self.table):
            limit_twist(self.table, self.dt)

    def _dynamic_rows(self) -> np.ndarray:
        return np.flatnonzero(~self.table.b["kinematic"])

    def _drive_dynamic_robots(self) -> None:
        world_motion.drive_dynamic_robots(self)  # wheel motor targets from the limited twist

    def _step_physics(self) -> None:
        if self.table.b["kinematic"].all() and not self.models.has_dynamic_models():
            return  # nothing moves under physics: skip the engine step (kinematic fleets)
        p.stepSimulation(physicsClientId=self.client)

    def _move_kinematic_robots(self) -> None:
        world_motion.move_kinematic_robots(self)  # unicycle integration, collisions resolved

    def _read_dynamic_robots(self) -> None:
        from sim.robot_spawn import read_dynamic_states

        rows = self._dynamic_rows()
        if rows.size:
            read_dynamic_states(self, rows)

    def _sample_sensors(self) -> None:
        world_sensors.sample_sensors(self)  # due lidars in one batched ray cast, IMU, odometry, contacts

    def _collect_dynamic_contacts(self) -> None:
        world_sensors.collect_dynamic_contacts(self)

    def _check_physics_health(self) -> None:
        world_motion.check_physics_health(self)

    # ---- sensors ---------------------------------------------------------------------------------------

    def set_raycaster(self, name: str) -> None:
        """Pick the ray-casting backend of lidar and cast_rays: "embree" or "pybullet" (sim/ray_backends.py)."""
        self.rays.select(name)

    @property
    def raycaster(self) -> str:
        return self.rays.name

    def cast_rays(self, origins: np.ndarray, ends: np.ndarray, layout: RayLayout | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
        """Batched ray cast: (hit fraction in [0, 1], body uid or -1) per ray, by the selected backend;
        `layout` (a lidar's fans, sim/raycast_layout.py) spares Embree recovering them from the rays."""
        return self.rays.cast(origins, ends, layout)

    def cast_rays_pybullet(self, origins: np.ndarray, ends: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """PyBullet rayTestBatch, split into ≤16,000-ray calls."""
        return cast_pybullet(self.client, origins, ends)

    def latest_scan(self, name: str) -> LidarScan | None:
        self._row(name)
        return self._scans.get(name)

    def latest_imu(self, name: str) -> ImuReading | None:
        i = self._row(name)
        return imu_reading(self.table, i) if self.table.f["imu_stamp"][i] > 0 else None

    def latest_odometry(self, name: str) -> OdometryReading | None:
        i = self._row(name)
        return odometry_reading(self.table, i) if self.table.f["odom_stamp"][i] > 0 else None

    def latest_contacts(self, name: str) -> ContactReading:
        self._row(name)
        raw = self._contacts.get(name, ())
        contacts = tuple(Contact(self.body_label(uid)[0], (pos[0], pos[1], pos[2]), float(force))
                         for uid, pos, force in raw)
        return ContactReading(name, self._time, contacts)

    def render_camera(self, name: str, *, rgb: bool = True, depth: bool = True, segmentation: bool = True,
                      which: str = "rgb") -> CameraImage:
        """Render the robot's RGB camera (`which="rgb"`, 640×480) or depth camera (`which="depth"`, 320×240)."""
        return world_sensors.render_camera(self, name, rgb=rgb, depth=depth, segmentation=segmentation, which=which)

    def set_sensor_fault(self, robot: str, sensor: str, *, dropout: bool = False, noise_scale: float = 1.0) -> None:
        """Failure injection: make a sensor stop publishing (dropout) or get noisier (noise_scale × σ)."""
        world_sensors.set_sensor_fault(self, robot, sensor, dropout=dropout, noise_scale=noise_scale)

    def subscribe(self, callback: Callable[[Reading], None],
                  kinds: Iterable[str] = ("scan", "imu", "odom", "contact")) -> Callable[[], None]:
        """Call `callback(reading)` for each new reading of the given kinds; returns the unsubscribe call."""
        entry = (frozenset(kinds), callback)
        self._listeners.append(entry)
        return lambda: self._listeners.remove(entry) if entry in self._listeners else None

    def _wants(self, kind: str) -> bool:
        return any(kind in kinds for kinds, _ in self._listeners)

    def _emit(self, kind: str, reading: Reading) -> None:
        for kinds, cb in self._listeners:
            if kind in kinds:
                cb(reading)

    # ---- labels, models, snapshots -------------------------------------------------------------------

    def _sync_labels(self) -> None:
        self.label_of = self.models.labels()
        for name, body in self.bodies.items():
            self.label_of[body.uid] = (name, body.link_names)
        self._ground_uids = self.models.ground_uids()

    def body_label(self, body_uid: int, link_index: int = -1) -> tuple[str, str]:
        """(model or robot name, link name) of a body uid, as found in ray hits and segmentation masks."""
        if body_uid not in self.label_of:
            return ("", "")
        name, links = self.label_of[body_uid]
        return (name, links.get(link_index, links.get(-1, "")))

    def snapshot(self) -> Any:
        return take_snapshot(self)

    def restore(self, snap: Any) -> None:
        restore_snapshot(self, snap)

    def close(self) -> None:
        if p.isConnected(physicsClientId=self.client):
            p.disconnect(physicsClientId=self.client)

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ---- models and physics (sim/world_models.py) -------------------------------------------------

    def spawn_model(self, **kw: Any) -> list[str]:
        return world_models.spawn_model(self, **kw)

    def remove_model(self, name: str) -> None:
        world_models.remove_model(self, name)

    def list_models(self) -> list[ModelState]:
        return [world_models.model_state(self, n) for n in [*self.models.names(), *self.table.names]]

    def get_model_state(self, name: str) -> ModelState:
        return world_models.model_state(self, name)

    def set_model_state(self, name: str, **kw: Any) -> ModelState:
        return world_models.set_model_state(self, name, **kw)

    def apply_force(self, name: str, force: tuple[float, float, float],
                    torque: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        world_models.apply_force(self, name, force, torque)

    def physics_properties(self) -> dict[str, Any]:
        return world_models.physics_properties(self)

    def set_physics_properties(self, **kw: Any) -> dict[str, Any]:
        return world_models.set_physics_properties(self, **kw)

    # ---- world files ---------------------------------------------------------------------------------

    @classmethod
    def from_sdf(cls, path: str | Path, *, model_path: list[str] | None = None, **kw: Any) -> World:
        world = cls(ground=False, **kw)
        world.load_sdf(path, model_path=model_path)
        return world

    def load_sdf(self, path: str | Path, *, model_path: list[str] | None = None) -> None:
        from sim.sdf_parser import parse_sdf

        desc = parse_sdf(str(path), model_path=model_path)
        self.models.load_description(desc)
        if self.name == "world":
            self.name = desc.name
        self._sync_labels()

    @property
    def description(self) -> Any:
        return self.models.description()

    def save_sdf(self, path: str | Path) -> None:
        from sim.sdf_writer import save_sdf

        save_sdf(self.models.description(), str(path))
