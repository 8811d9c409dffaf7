"""`fleetnav serve --transport http` on 127.0.0.1 (a free port): the same drive through streamable HTTP, the
bearer token enforced, and a non-loopback bind refused without one."""

from __future__ import annotations

import subprocess
from collections.abc import Iterator

import anyio
import httpx2
import pytest
from mcp.client import Client
from mcp.client.streamable_http import streamable_http_client

from fleet.grading.agent_run import free_port
from tests.e2e.test_mcp_stdio import FLEETNAV, drive_to_goal

pytestmark = pytest.mark.anyio
TOKEN = "e2e-token-0123456789abcdef"


@pytest.fixture(scope="module")
def anyio_backend() -> str:
    return "asyncio"


@pytest.fixture
def http_server(tmp_path) -> Iterator[str]:
    port = free_port()
    proc = subprocess.Popen([FLEETNAV, "serve", "--transport", "http", "--port", str(port), "--world", "empty",
                             "--speed", "10", "--workspace", str(tmp_path), "--token", TOKEN],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        yield f"http://127.0.0.1:{port}/mcp"
    finally:
        proc.terminate()
        proc.wait(timeout=20)


async def _wait_up(url: str) -> httpx2.Response:
    async with httpx2.AsyncClient() as hc:
        for _ in range(300):
            try:
                return await hc.post(url, json={"jsonrpc": "2.0", "id": 1, "method": "tools/list"}, timeout=2,
                                     headers={"Accept": "application/json, text/event-stream"})
            except httpx2.TransportError:
                await anyio.sleep(0.1)
    raise AssertionError(f"{url} never came up")


async def test_http_server_requires_the_token_and_drives_a_robot(http_server: str) -> None:
    anonymous = await _wait_up(http_server)
    assert anonymous.status_code == 401 and "Bearer" in anonymous.headers["www-authenticate"]
    async with httpx2.AsyncClient(headers={"Authorization": "Bearer wrong-token-0123456789"}) as hc:
        r = await hc.post(http_server, json={"jsonrpc": "2.0", "id": 1, "method": "tools/list"})
        assert r.status_code == 401
    hc = httpx2.AsyncClient(headers={"Authorization": f"Bearer {TOKEN}"})
    async with Client(streamable_http_client(http_server, http_client=hc)) as c:
        await drive_to_goal(c)


def test_binding_beyond_loopback_needs_a_token() -> None:
    r = subprocess.run([FLEETNAV, "serve", "--transport", "http", "--host", "0.0.0.0"], capture_output=True,
                       text=True, timeout=60, env={"PATH": "/usr/bin:/bin"})
    assert r.returncode == 2 and "--token" in r.stderr
