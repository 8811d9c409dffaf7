"""The Zenoh API of fleetnav: the one owner of the key-expression scheme, the payload schemas and their codecs.

Keys are versioned: `fleetnav/@v1/<world>/...` (docs/zenoh-api.md has the table: key, direction, rate, payload).
`@v1` is a Zenoh verbatim chunk: wildcards never match it, so `fleetnav/**` does not silently mix versions;
subscribe to `fleetnav/@v1/<world>/**` instead. Every payload is JSON (UTF-8) carrying `stamp`, the sim time;
scans carry their ranges as base64 little-endian float32 (+inf = no return), as JSON floats are slow and
lossy. Requests are validated by strict models: unknown fields and non-finite numbers are errors.
"""

from __future__ import annotations

import base64
import json
import math
import re
from dataclasses import dataclass
from typing import Annotated, Any, Literal, TypeVar

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from fleet.types import Event, FleetSnapshot
from sim.errors import ErrorCode, FleetError
from sim.types import ImuReading, LidarScan, OdometryReading

ROOT = "fleetnav/@v1"
ROBOT_STREAMS = ("odom", "scan", "imu", "pose", "state")
COMMANDS = ("navigate", "cancel", "task_status", "spawn", "remove", "reset", "drive", "lease", "override", "estop",
            "rearm", "lockstep", "sync")
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.\-]{0,63}$")


def check_name(kind: str, name: str) -> str:
    """Names become key chunks: no '/', wildcards or '$'."""
    if not _NAME.match(name):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"invalid {kind} '{name}'",
                         "use 1–64 letters, digits, '_', '-', '.', starting with a letter or digit")
    return name


# ---- keys ---------------------------------------------------------------------------------------------------


class Keys:
    """Every key of one world. The world side and the agent side build keys only through this class."""

    def __init__(self, world: str) -> None:
        self.world = check_name("world key", world)
        self.base = f"{ROOT}/{world}"

    def robot(self, robot: str, topic: str) -> str:  # odom scan imu pose state camera cmd_vel
        return f"{self.base}/robot/{robot}/{topic}"

    def robot_any(self, topic: str) -> str:
        return f"{self.base}/robot/*/{topic}"

    def fleet(self, topic: str) -> str:  # state events clock errors map tasks
        return f"{self.base}/fleet/{topic}"

    def command(self, op: str) -> str:
        return f"{self.base}/fleet/command/{op}"

    def agent_errors(self, agent: str) -> str:
        return f"{self.base}/agent/{agent}/errors"

    def agent_heartbeat(self, agent: str) -> str:
        return f"{self.base}/agent/{agent}/heartbeat"

    def alive_world(self) -> str:
        return f"{self.base}/alive/world"

    def alive_robot(self, robot: str) -> str:
        return f"{self.base}/alive/robot/{robot}"

    def alive_agent(self, agent: str) -> str:
        return f"{self.base}/alive/agent/{agent}"

    def robot_of(self, key: str) -> str:
        """The robot chunk of `<base>/robot/<robot>/<topic>`."""
        head = f"{self.base}/robot/"
        if not key.startswith(head) or key.count("/") != head.count("/") + 1:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"'{key}' is not a robot key of world '{self.world}'")
        return key[len(head):].split("/", 1)[0]

    @staticmethod
    def last(key: str) -> str:
        return key.rsplit("/", 1)[-1]

    @staticmethod
    def worlds_pattern() -> str:
        return f"{ROOT}/*/alive/world"

    @staticmethod
    def world_of(alive_key: str) -> str:
        return alive_key[len(ROOT) + 1:].split("/", 1)[0]


class RosKeys:
    """ROS 2 topic keys as zenoh-bridge-ros2dds maps them: topic `/r1/cmd_vel` ↔ key `<prefix>/r1/cmd_vel`."""

    def __init__(self, prefix: str = "") -> None:
        self.prefix = prefix.strip("/")

    def topic(self, robot: str, name: str) -> str:
        return f"{self.prefix}/{robot}/{name}" if self.prefix else f"{robot}/{name}"

    def robot_of(self, key: str) -> str:
        rel = key[len(self.prefix) + 1:] if self.prefix else key
        return rel.split("/", 1)[0]


# ---- request schemas (agent → world) -----------------------------------------------------------------------

Finite = Annotated[float, Field(allow_inf_nan=False)]


class Msg(BaseModel):
    model_config = ConfigDict(extra="forbid")


class Request(Msg):
    agent: str = Field("zenoh", description="the client id commands act under (leases, events)")


class CmdVel(Msg):
    """`robot/<id>/cmd_vel`: a velocity command through the safety envelope (held until the deadman)."""

    v: Finite
    w: Finite
    agent: str = "zenoh"
    tick: int | None = Field(None, description="lock-step: the clock tick this command answers")
    seq: int | None = Field(None, ge=0, description="the agent's running count, for loss accounting")
    sent: float | None = Field(None, description="wall time.time() when sent, for latency measurement")
    duration: Finite | None = Field(None, gt=0, le=3600, description="hold for this many sim s instead")


class PoseIn(Msg):
    x: Finite
    y: Finite
    yaw: Finite = 0.0


class NavigateReq(Request):
    robot: str
    goal: PoseIn
    align_yaw: bool = False


class TaskReq(Request):
    task_id: str


class SpawnReq(Request):
    name: str
    pose: PoseIn
    model: str | None = None
    fidelity: Literal["kinematic", "dynamic"] | None = None
    namespace: str | None = None


class RobotReq(Request):
    name: str


class EmptyReq(Request):
    pass


class DriveReq(Request):
    robot: str
    v: Finite
    w: Finite
    duration: Finite | None = Field(None, gt=0, le=3600)


class LeaseReq(Request):
    robot: str
    release: bool = False
    ttl_s: Finite | None = Field(None, gt=0, le=3600)


class OverrideReq(Request):
    """An operator takes a robot from whichever agent holds it (the `agent` field names the operator)."""

    robot: str
    reason: str = Field("operator override", max_length=500)
    hold_s: Finite | None = Field(None, gt=0, le=3600, description="the operator's lease idle expiry")


class Heartbeat(Msg):
    """`agent/<id>/heartbeat`: the SDK's liveness beat; a world that misses 2 of them reports the agent."""

    agent: str
    period: Finite = Field(gt=0, le=60, description="seconds between beats")
    seq: int = Field(ge=0)


class EstopReq(Request):
    robot: str | None = Field(None, description="null: the whole fleet")
    reason: str = "e-stop over zenoh"


class RearmReq(Request):
    robot: str | None = None


class LockstepReq(Request):
    robots: list[str] = Field(description="robots this agent commands every tick; [] leaves lock-step")


class TasksReq(Msg):
    robot: str | None = None
    include_done: bool = False


class CameraReq(Msg):
    which: Literal["rgb", "depth"] = "rgb"


M = TypeVar("M", bound=BaseModel)


def decode(model: type[M], payload: bytes | None, what: str) -> M:
    """Parse and validate a JSON request; a bad one is INVALID_ARGUMENT naming the field."""
    try:
        data = json.loads(payload) if payload else {}
    except (UnicodeDecodeError, ValueError) as exc:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{what}: payload is not JSON ({exc})",
                         f"send a JSON object with fields: {', '.join(model.model_fields)}") from exc
    except RecursionError:  # `[[[[...` thousands deep: the parser gives up (no request nests that deep)
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{what}: payload nests too deeply",
                         f"send a flat JSON object with fields: {', '.join(model.model_fields)}") from None
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        e = exc.errors()[0]
        where = ".".join(str(p) for p in e["loc"]) or "(payload)"
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{what}: field '{where}': {e['msg']}",
                         f"fields: {', '.join(model.model_fields)}") from exc


# ---- encoders (world → agent); hot ones are formatted by hand, json.dumps costs ~10x ----------------------


def dumps(obj: Any) -> bytes:
    return json.dumps(obj, separators=(",", ":"), allow_nan=False, default=_plain).encode()


def _plain(o: Any) -> Any:
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    if hasattr(o, "to_dict"):
        return o.to_dict()
    if hasattr(o, "__dataclass_fields__"):
        return {k: getattr(o, k) for k in o.__dataclass_fields__}
    raise TypeError(f"cannot encode {type(o).__name__}")


def _f(x: float) -> str:
    return repr(float(x)) if math.isfinite(x) else "null"


def encode_odom(r: OdometryReading) -> bytes:
    p = r.pose
    return (f'{{"stamp":{r.stamp!r},"frame_id":"odom","child_frame_id":"base_link","x":{_f(p.x)},"y":{_f(p.y)},'
            f'"yaw":{_f(p.yaw)},"v":{_f(r.linear)},"w":{_f(r.angular)},"left_wheel":{_f(r.left_wheel)},'
            f'"right_wheel":{_f(r.right_wheel)}}}').encode()


def encode_pose(stamp: float, x: float, y: float, yaw: float) -> bytes:
    return f'{{"stamp":{stamp!r},"frame_id":"map","x":{_f(x)},"y":{_f(y)},"yaw":{_f(yaw)}}}'.encode()


def encode_scan(s: LidarScan) -> bytes:
    ranges = base64.b64encode(np.ascontiguousarray(s.ranges, dtype="<f4").tobytes()).decode()
    return (f'{{"stamp":{s.stamp!r},"frame_id":"lidar","angle_min":{s.angle_min!r},'
            f'"angle_increment":{s.angle_increment!r},"range_min":{s.range_min!r},"range_max":{s.range_max!r},'
            f'"count":{s.ranges.size},"ranges":"{ranges}"}}').encode()


def encode_imu(r: ImuReading) -> bytes:
    return dumps({"stamp": r.stamp, "frame_id": "imu", "orientation": r.orientation,
                  "angular_velocity": r.angular_velocity, "linear_acceleration": r.linear_acceleration})


def encode_robot_state(snap: FleetSnapshot, i: int) -> bytes:
    return dumps({"stamp": snap.time, **snap.robot(snap.names[i]).to_dict("full")})


def encode_fleet_state(snap: FleetSnapshot, tick: int) -> bytes:
    """One message for the whole fleet, arrays in `names` order: scales to hundreds of robots."""
    return dumps({"stamp": snap.time, "tick": tick, "step": snap.step_count, "world": snap.world,
                  "clock": snap.clock_mode, "names": snap.names, "x": snap.pose[:, 0], "y": snap.pose[:, 1],
                  "yaw": snap.pose[:, 2], "v": snap.twist[:, 0], "w": snap.twist[:, 1], "cmd_v": snap.cmd[:, 0],
                  "cmd_w": snap.cmd[:, 1], "battery": snap.battery, "in_collision": snap.in_collision,
                  "estopped": snap.estopped, "controller": snap.controller, "lease": snap.lease,
                  "fleet_estopped": snap.fleet_estopped, "active_tasks": snap.active_tasks,
                  "last_event_seq": snap.last_event_seq})


def encode_event(ev: Event) -> bytes:
    return dumps(ev.to_dict())


def encode_result(stamp: float, result: Any) -> bytes:
    """A query's successful reply."""
    return dumps({"stamp": stamp, "result": result})


def encode_error(exc: FleetError, stamp: float, **context: Any) -> bytes:
    """A query's error reply, and the payload of `fleet/errors` / `agent/<id>/errors`: the same code, message
    and hint the MCP tools return."""
    return dumps({"stamp": stamp, **exc.to_dict(), **context})


def decode_error(payload: bytes) -> FleetError:
    try:
        d = json.loads(payload)
        return FleetError(ErrorCode(d["code"]), str(d["message"]), str(d.get("hint", "")))
    except (ValueError, KeyError, TypeError):
        return FleetError(ErrorCode.INTERNAL, f"unreadable error reply: {payload[:200]!r}")


# ---- decoded messages (agent side) ----------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Odom:
    stamp: float
    x: float
    y: float
    yaw: float  # odom frame (starts at the spawn pose), drifts like real wheel odometry
    v: float
    w: float


@dataclass(frozen=True, slots=True)
class PoseStamped:
    stamp: float
    x: float
    y: float
    yaw: float  # map frame, ground truth


@dataclass(frozen=True, slots=True)
class Scan:
    stamp: float
    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float
    ranges: np.ndarray  # float32, +inf = no return

    def angles(self) -> np.ndarray:
        return self.angle_min + self.angle_increment * np.arange(self.ranges.size)


def decode_odom(payload: bytes) -> Odom:
    d = json.loads(payload)
    return Odom(d["stamp"], d["x"], d["y"], d["yaw"], d["v"], d["w"])


def decode_pose(payload: bytes) -> PoseStamped:
    d = json.loads(payload)
    return PoseStamped(d["stamp"], d["x"], d["y"], d["yaw"])


def decode_scan(payload: bytes) -> Scan:
    d = json.loads(payload)
    ranges = np.frombuffer(base64.b64decode(d["ranges"]), dtype="<f4")
    if ranges.size != d["count"]:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"scan has {ranges.size} ranges, header says {d['count']}")
    return Scan(d["stamp"], d["angle_min"], d["angle_increment"], d["range_min"], d["range_max"], ranges)


def encode_map(stamp: float, data: np.ndarray, resolution: float, origin: tuple[float, float]) -> bytes:
    """An occupancy grid like nav_msgs/OccupancyGrid: int8 row-major from the lower-left cell (0 free, 100
    occupied, -1 unknown), base64."""
    h, w = data.shape
    return dumps({"stamp": stamp, "frame_id": "map", "resolution": resolution, "width": w, "height": h,
                  "origin": {"x": origin[0], "y": origin[1], "yaw": 0.0}, "encoding": "int8/base64",
                  "data": base64.b64encode(np.ascontiguousarray(data, dtype=np.int8).tobytes()).decode()})


def encode_image(stamp: float, pixels: np.ndarray, encoding: Literal["rgb8", "32FC1"], fov_deg: float) -> bytes:
    """A camera frame like sensor_msgs/Image: row-major from the top row, base64 (depth: float32 metres)."""
    h, w = pixels.shape[:2]
    dtype = "<u1" if encoding == "rgb8" else "<f4"
    return dumps({"stamp": stamp, "width": w, "height": h, "encoding": encoding, "fov_deg": fov_deg,
                  "data": base64.b64encode(np.ascontiguousarray(pixels, dtype=dtype).tobytes()).decode()})


def decode_grid(d: dict[str, Any]) -> np.ndarray:
    return np.frombuffer(base64.b64decode(d["data"]), dtype=np.int8).reshape(d["height"], d["width"])
