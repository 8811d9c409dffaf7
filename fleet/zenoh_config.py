"""Configuration of the Zenoh front door: network (endpoints, mode, scouting, TLS, access control), lock-step, ROS 2.

Security settings are passed through to Zenoh's own JSON5 configuration unchanged (Zenoh validates them when
the session opens), so anything Zenoh supports — mTLS, user/password auth, ACL policies — is available
without this file knowing about it. See configs/zenoh/ for samples, including a locked-down one.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from pydantic import Field, field_validator

from sim.config import StrictModel, load_yaml
from sim.errors import ErrorCode, FleetError

if TYPE_CHECKING:
    import zenoh

_ENDPOINT = re.compile(r"^(tcp|udp|tls|quic|ws|unixsock-stream|serial)/\S+$")


class TlsConfig(StrictModel):
    """Zenoh's `transport/link/tls` section (paths to PEM files)."""

    root_ca_certificate: str | None = Field(None, description="CA that signed the other side's certificate")
    listen_private_key: str | None = None
    listen_certificate: str | None = None
    connect_private_key: str | None = Field(None, description="client key, for mutual TLS")
    connect_certificate: str | None = Field(None, description="client certificate, for mutual TLS")
    enable_mtls: bool = Field(False, description="require a client certificate from whoever connects")
    verify_name_on_connect: bool = Field(True, description="check the server certificate's name")


class LockstepConfig(StrictModel):
    enabled: bool = Field(False, description="the world waits each control tick for every registered agent")
    timeout_s: float = Field(5.0, gt=0, le=600, description="wall seconds before a silent agent is declared hung")


class Ros2Config(StrictModel):
    """ROS-style keys with CDR payloads, as zenoh-bridge-ros2dds maps ROS 2 topics (`/r1/cmd_vel` ↔ `r1/cmd_vel`)."""

    enabled: bool = False
    prefix: str = Field("", description="key prefix, e.g. the bridge's namespace without the leading '/'")
    client: str = Field("ros2", description="client id ROS commands act under (leases, events)")


class StreamsConfig(StrictModel):
    """Which per-robot streams the world publishes (each only while someone subscribes)."""

    odom: bool = True
    scan: bool = True
    imu: bool = True
    pose: bool = True
    state: bool = True


class AgentsConfig(StrictModel):
    """How the world treats agents' leases and command rates (null: the FleetConfig's safety section)."""

    lease_idle_s: float | None = Field(None, gt=0, le=3600, description="a lease lapses after this long idle, s")
    robot_rate_hz: float | None = Field(None, gt=0, description="commands/s per robot; null: 4 × control_hz")
    agent_rate_hz: float | None = Field(None, gt=0, description="commands/s per agent (fleet controllers)")

    def safety_update(self) -> dict[str, float]:
        return {k: v for k, v in self.model_dump().items() if v is not None}


class ZenohConfig(StrictModel):
    mode: Literal["peer", "client", "router"] = "peer"
    listen: list[str] = Field(default_factory=list, description="endpoints to listen on, e.g. tcp/0.0.0.0:7447")
    connect: list[str] = Field(default_factory=list, description="endpoints to connect to")
    multicast_scouting: bool = Field(True, description="discover peers on the LAN by multicast")
    tls: TlsConfig | None = None
    access_control: dict[str, Any] | None = Field(None, description="Zenoh's `access_control` section, verbatim")
    zenoh_config_file: str | None = Field(None, description="a Zenoh JSON5 config used as the base")
    zenoh_settings: dict[str, Any] = Field(default_factory=dict,
                                  description="more Zenoh settings by path, e.g. {'transport/unicast/max_links': 4}")
    world_key: str | None = Field(None, description="the <world> key segment; default: the world's name")
    lockstep: LockstepConfig = Field(default_factory=LockstepConfig)
    ros2: Ros2Config = Field(default_factory=Ros2Config)
    streams: StreamsConfig = Field(default_factory=StreamsConfig)
    query_workers: int = Field(4, ge=1, le=64, description="threads that decode and answer queries")
    query_budget_s: float = Field(5.0, gt=0, le=60, description="wall seconds the world has to answer a query; "
                                  "then it is answered TIMEOUT (below a caller's usual 10 s)")
    control_hz: float | None = Field(None, ge=1, le=200, description="the world's control rate (FleetConfig); "
                                     "null: the fleet config's")
    odom_hz: float | None = Field(None, gt=0, le=1000, description="publish odom at most this often (sim time); "
                                  "null: every odometry reading (the robot model's rate)")
    state_hz: float | None = Field(None, gt=0, le=200, description="publish pose/state at most this often "
                                   "(sim time, ≤ control_hz: they follow control ticks); null: every control tick")
    agents: AgentsConfig = Field(default_factory=AgentsConfig)

    @field_validator("listen", "connect")
    @classmethod
    def _endpoints(cls, v: list[str]) -> list[str]:
        for e in v:
            if not _ENDPOINT.match(e):
                raise ValueError(f"endpoint '{e}' is not <protocol>/<address>, e.g. tcp/127.0.0.1:7447")
        return v

    def check_rates(self, control_hz: float) -> None:
        """The rates against the world's control rate: the config cannot change a running world's."""
        if self.control_hz is not None and abs(self.control_hz - control_hz) > 1e-9:
            raise FleetError(ErrorCode.INVALID_CONFIG, f"zenoh config control_hz {self.control_hz:g} differs from "
                             f"the world's {control_hz:g}", "build the FleetService with this control_hz "
                             "(`fleetnav zenoh` does it for you)")
        if self.state_hz is not None and self.state_hz > control_hz + 1e-9:
            raise FleetError(ErrorCode.INVALID_CONFIG, f"state_hz {self.state_hz:g} exceeds control_hz "
                             f"{control_hz:g}: pose and state are published after control ticks",
                             f"use state_hz ≤ {control_hz:g} or raise control_hz")

    def to_zenoh(self) -> zenoh.Config:
        """The Zenoh session config: the base file (if any), then these settings on top."""
        import zenoh

        try:
            cfg = zenoh.Config.from_file(self.zenoh_config_file) if self.zenoh_config_file else zenoh.Config()
            for key, value in self.json5_settings().items():
                cfg.insert_json5(key, json.dumps(value))
        except zenoh.ZError as exc:
            raise FleetError(ErrorCode.INVALID_CONFIG, f"zenoh config: {exc}",
                             "see the Zenoh configuration reference (DEFAULT_CONFIG.json5)") from exc
        return cfg

    def json5_settings(self) -> dict[str, Any]:
        """Zenoh config path → value, in the order they are applied."""
        out: dict[str, Any] = {"mode": self.mode, "scouting/multicast/enabled": self.multicast_scouting}
        if self.listen:
            out["listen/endpoints"] = self.listen
        if self.connect:
            out["connect/endpoints"] = self.connect
        if self.tls is not None:
            out["transport/link/tls"] = self.tls.model_dump(exclude_none=True)
        if self.access_control is not None:
            out["access_control"] = self.access_control
        out.update(self.zenoh_settings)
        return out


def load_zenoh_config(path: str | Path) -> ZenohConfig:
    return load_yaml(path, ZenohConfig)


def loopback(port: int, *, listen: bool, **kw: Any) -> ZenohConfig:
    """A session on 127.0.0.1 only, no multicast: what tests and local runs use."""
    ep = [f"tcp/127.0.0.1:{port}"]
    return ZenohConfig(listen=ep if listen else [], connect=[] if listen else ep, multicast_scouting=False, **kw)
