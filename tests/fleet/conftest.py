from __future__ import annotations

from collections.abc import Iterator

import pytest

from fleet import FleetConfig, FleetService


@pytest.fixture
def service() -> Iterator[FleetService]:
    svc = FleetService(FleetConfig(world="empty", seed=1))
    yield svc
    svc.close()
