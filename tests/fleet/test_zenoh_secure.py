"""The locked-down sample (configs/zenoh/secure.yaml) for real: mutual TLS and access control on loopback.

Certificates come from a throwaway CA made with the openssl command line; an agent's certificate name decides
what the world lets it do."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from fleet.agent import Agent
from fleet.zenoh_config import TlsConfig, ZenohConfig, load_zenoh_config
from sim.errors import ErrorCode, FleetError
from tests.fleet.zenoh_util import ROOT, free_port, served, wait_until

pytestmark = pytest.mark.skipif(shutil.which("openssl") is None, reason="needs the openssl command line")


def _pki(d: Path) -> None:
    def run(*args: str) -> None:
        subprocess.run(["openssl", *args], cwd=d, check=True, capture_output=True)

    ec = ["-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes"]
    run("req", "-x509", *ec, "-keyout", "ca-key.pem", "-out", "ca.pem", "-days", "1", "-subj", "/CN=test CA")
    for name, cn, san in (("world", "localhost", "DNS:localhost,IP:127.0.0.1"),
                          ("agent", "agent.fleetnav.local", "DNS:agent.fleetnav.local"),
                          ("operator", "operator.fleetnav.local", "DNS:operator.fleetnav.local"),
                          ("observer", "observer.fleetnav.local", "DNS:observer.fleetnav.local")):
        run("req", *ec, "-keyout", f"{name}-key.pem", "-out", f"{name}.csr", "-subj", f"/CN={cn}")
        (d / f"{name}.ext").write_text(f"subjectAltName={san}\nbasicConstraints=CA:FALSE\n"
                                       "extendedKeyUsage=serverAuth,clientAuth\n")
        run("x509", "-req", "-in", f"{name}.csr", "-CA", "ca.pem", "-CAkey", "ca-key.pem", "-CAcreateserial",
            "-out", f"{name}.pem", "-days", "1", "-extfile", f"{name}.ext")


def _agent_config(d: Path, port: int, who: str | None) -> ZenohConfig:
    cfg = load_zenoh_config(ROOT / "configs" / "zenoh" / "agent_secure.yaml")
    tls = TlsConfig(root_ca_certificate=str(d / "ca.pem"))
    if who is not None:
        tls = TlsConfig(root_ca_certificate=str(d / "ca.pem"), connect_private_key=str(d / f"{who}-key.pem"),
                        connect_certificate=str(d / f"{who}.pem"), enable_mtls=True)
    return cfg.model_copy(update={"connect": [f"tls/localhost:{port}"], "tls": tls})


def test_the_locked_down_config_admits_agents_by_certificate_and_role(tmp_path):
    _pki(tmp_path)
    port = free_port()
    secure = load_zenoh_config(ROOT / "configs" / "zenoh" / "secure.yaml")
    assert secure.tls is not None and secure.tls.enable_mtls and secure.access_control is not None
    tls = secure.tls.model_copy(update={"root_ca_certificate": str(tmp_path / "ca.pem"),
                                        "listen_private_key": str(tmp_path / "world-key.pem"),
                                        "listen_certificate": str(tmp_path / "world.pem")})
    world_cfg = secure.model_copy(update={"listen": [f"tls/localhost:{port}"], "tls": tls})
    with served(robots={"r1": (0.0, 0.0, 0.0)}, config=world_cfg) as (svc, bridge, _):
        with Agent("pilot", config=_agent_config(tmp_path, port, "agent"), timeout=5) as pilot:
            assert pilot.fleet_state()["names"] == ["r1"]
            assert pilot.robot("r1").drive_sync(0.2, 0.0)["applied_v"] == 0.2
            assert pilot.robot("r1").wait("pose").stamp >= 0
            wait_until(lambda: "pilot" in bridge.watchdog.beats, timeout=5, what="the pilot's heartbeat")
            with pytest.raises(FleetError) as e:  # agents may not take robots from each other
                pilot.query(bridge.keys.command("override"), {"robot": "r1", "agent": "pilot"}, timeout=1.0)
            assert e.value.code is ErrorCode.TIMEOUT
            with Agent("ops", config=_agent_config(tmp_path, port, "operator"), timeout=5) as ops:
                assert ops.override("r1", "test")["previous"] == "pilot"
                assert svc.safety.holder("r1") == "ops"
            wait_until(lambda: svc.safety.holder("r1") is None, what="the operator's lease released as it left")
            pilot.request("lease", robot="r1", release=True)
        with Agent("watcher", config=_agent_config(tmp_path, port, "observer"), timeout=2) as watcher:
            assert watcher.fleet_state()["names"] == ["r1"]  # reading is allowed
            assert watcher.robot("r1").wait("pose").stamp >= 0
            received = bridge.stats()["commands"]["received"]
            watcher.robot("r1").drive(0.5, 0.0)  # dropped at the world's door: observers may not command
            with pytest.raises(FleetError) as e:
                watcher.robot("r1").drive_sync(0.5, 0.0)  # the query never reaches the world: no reply
            assert e.value.code is ErrorCode.TIMEOUT
            assert bridge.stats()["commands"]["received"] == received and svc.safety.holder("r1") is None
        with pytest.raises(Exception, match="Unable to connect"):  # no client certificate: no connection at all
            Agent("stranger", config=_agent_config(tmp_path, port, None), timeout=2).open()
