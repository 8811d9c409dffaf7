"""Run the peer, pybullet-fleet 0.8.0, on our scene in its own throwaway venv (never one of our dependencies).

The venv is created on first use (`python -m venv /tmp/pbf && /tmp/pbf/bin/pip install pybullet-fleet==0.8.0`);
if that fails the reason is returned and printed instead of a figure.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from _sim_scene import Scene

from sim import RobotSpec

PEER_VENV = Path("/tmp/pbf")
PEER_PYTHON = PEER_VENV / "bin" / "python"
PEER_PACKAGE = "pybullet-fleet==0.8.0"
WORKLOAD = Path(__file__).resolve().parent / "_pbf_workload.py"


@dataclass(frozen=True)
class PeerResult:
    robots: int
    steps: int
    wall_s: float
    cpu_s: float
    moved: float  # mean share of robots whose pose changed per step
    collisions_started: int  # collision pairs the peer detected (and let robots pass through)
    version: str

    @property
    def rtf(self) -> float:
        return self.steps * 0.1 / self.wall_s

    @property
    def rtf_cpu(self) -> float:
        return self.steps * 0.1 / self.cpu_s

    @property
    def robot_steps_per_s(self) -> float:
        return self.robots * self.steps / self.wall_s


def _peer_version() -> str | None:
    probe = "import importlib.metadata as m; print(m.version('pybullet-fleet'))"
    try:
        out = subprocess.run([str(PEER_PYTHON), "-c", probe], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return out.stdout.strip() if out.returncode == 0 else None


def ensure_peer() -> str:
    """The installed peer version, installing it first if needed. Raises RuntimeError with the reason."""
    version = _peer_version() if PEER_PYTHON.exists() else None
    if version is None:
        for cmd in ([sys.executable, "-m", "venv", str(PEER_VENV)],
                    [str(PEER_VENV / "bin" / "pip"), "install", "-q", PEER_PACKAGE]):
            try:
                done = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
            except (OSError, subprocess.TimeoutExpired) as exc:
                raise RuntimeError(f"`{' '.join(cmd)}` failed: {exc}") from exc
            if done.returncode != 0:
                last = (done.stderr.strip().splitlines() or [f"exit code {done.returncode}"])[-1]
                raise RuntimeError(f"`{' '.join(cmd)}` failed: {last}")
        version = _peer_version()
    if version is None:
        raise RuntimeError(f"{PEER_PACKAGE} is not importable from {PEER_PYTHON}")
    return version


def run_peer(scene: Scene, spec: RobotSpec, steps: int, warmup: int, robot: str = "box",
             urdf: str = "") -> PeerResult:
    """The peer's workload on `scene` (see _pbf_workload.py). robot: "box" (the footprint box of our
    kinematic proxy: one box collision shape) or "urdf" (our full robot URDF at `urdf`)."""
    ensure_peer()
    hx = spec.chassis.size[0] / 2
    hy = max(spec.chassis.size[1] / 2, spec.wheels.separation / 2 + spec.wheels.width / 2)
    top, bottom = spec.chassis_z + spec.chassis.size[2] / 2, 0.02
    lim = spec.limits
    job: dict[str, Any] = {
        **scene.peer_json(), "seed": 3, "steps": steps, "warmup": warmup, "check_obstacles": True,
        "robot": robot, "urdf": urdf, "urdf_z": 0.0, "box_half": [hx, hy, (top - bottom) / 2],
        "box_z": (top + bottom) / 2, "mass": spec.total_mass,
        "limits": {"v": lim.max_linear, "w": lim.max_angular, "a": lim.max_linear_accel,
                   "alpha": lim.max_angular_accel},
    }
    with tempfile.TemporaryDirectory(prefix="fleetnav_peer_") as tmp:
        path = Path(tmp) / "scene.json"
        path.write_text(json.dumps(job), encoding="utf-8")
        done = subprocess.run([str(PEER_PYTHON), str(WORKLOAD), str(path)], capture_output=True, text=True,
                              timeout=3600)
    if done.returncode != 0:
        raise RuntimeError(f"peer workload failed: {done.stderr.strip()[-800:]}")
    out = json.loads(done.stdout.strip().splitlines()[-1])
    return PeerResult(out["robots"], out["steps"], out["wall_s"], out["cpu_s"], out["moved_fraction"],
                      out["collisions_started"], out["version"])
