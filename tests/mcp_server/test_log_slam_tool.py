"""run_slam_on_log: a simulated CARMEN log in the workspace is mapped; metrics + map image come back; paths
outside the workspace and unknown config fields are refused."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.mcp_server.helpers import err, image
from tests.slam import carmen_synth

pytestmark = pytest.mark.anyio


async def test_run_slam_on_log(client, workspace: Path) -> None:
    rng = np.random.default_rng(1)
    truth = carmen_synth.loop(60, 0.25)
    (workspace / "logs").mkdir(exist_ok=True)
    carmen_synth.write_log(workspace / "logs" / "lap.log", truth, carmen_synth.drifted(truth, 0.01, rng), rng)
    img, meta = await image(client, "run_slam_on_log", {"path": "logs/lap.log", "max_px": 400})
    r = meta["result"]
    assert max(img.shape[:2]) <= 400 and r["scans"] == 60
    assert r["slam"]["ate_rmse"] < 0.05 < r["odometry_only"]["ate_rmse"]  # against the log's reference poses
    assert (workspace / "outputs" / "slam" / "lap" / "trajectory.tum").is_file()
    assert "no readable log file" in await err(client, "run_slam_on_log", {"path": "/etc/passwd"})
    (workspace / "outputs" / "mine").mkdir()
    (workspace / "outputs" / "mine" / "notes.txt").write_text("not the server's")
    assert "did not write" in await err(client, "run_slam_on_log", {"path": "logs/lap.log", "out": "mine"})
    assert (workspace / "outputs" / "mine" / "notes.txt").read_text() == "not the server's"
    assert "config.bogus" in await err(client, "run_slam_on_log", {"path": "logs/lap.log", "config": {"bogus": 1}})
