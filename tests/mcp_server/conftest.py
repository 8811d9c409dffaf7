"""One FleetService + MCP server per test module (building the server's ~100 tool schemas takes ~0.5 s),
reset to a fresh world before every test; each test talks to it through the SDK's in-memory Client."""

from __future__ import annotations

from collections.abc import AsyncIterator, Iterator
from pathlib import Path

import pytest
from mcp.client import Client
from mcp.server.mcpserver import MCPServer

from fleet import FleetConfig, FleetService
from mcp_server.server import build_server


@pytest.fixture(scope="session")
def anyio_backend() -> str:
    return "asyncio"


@pytest.fixture(scope="module")
def world_name() -> str:
    return "empty"


@pytest.fixture(scope="module")
def workspace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("ws")


@pytest.fixture(scope="module")
def service(world_name: str, workspace: Path) -> Iterator[FleetService]:
    svc = FleetService(FleetConfig(world=world_name, seed=3, workspace=str(workspace)))
    yield svc
    svc.close()


@pytest.fixture(scope="module")
def server(service: FleetService) -> MCPServer:
    return build_server(service)


@pytest.fixture
async def client(server: MCPServer, service: FleetService) -> AsyncIterator[Client]:
    service.reset()
    async with Client(server) as c:
        yield c
