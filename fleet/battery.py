"""Battery model: drain by distance and time, charging when still at a dock. Vectorised over the fleet."""

from __future__ import annotations

import numpy as np

from fleet.config import BatteryConfig


class BatteryBank:
    def __init__(self, config: BatteryConfig) -> None:
        self.config = config
        self.soc = np.zeros(0)  # state of charge 0..1, one per robot in world order
        self.docks = np.zeros((0, 2))
        self._low: set[int] = set()

    def resize(self, names: list[str], previous: list[str], soc0: dict[str, float]) -> None:
        old = dict(zip(previous, self.soc.tolist(), strict=True))
        self.soc = np.array([old.get(n, soc0.get(n, 1.0)) for n in names], dtype=float)
        self._low = set()

    def update(self, dt: float, travelled: np.ndarray, xy: np.ndarray, speed: np.ndarray) -> np.ndarray:
        """Advance by dt; returns indices that just crossed the low threshold (for low_battery events)."""
        c = self.config
        used_wh = c.idle_w * dt / 3600.0 + c.drive_wh_per_m * travelled
        charging = np.zeros(len(self.soc), dtype=bool)
        if len(self.docks) and len(self.soc):
            d = np.min(np.linalg.norm(xy[:, None, :] - self.docks[None, :, :], axis=2), axis=1)
            charging = (d < c.dock_radius) & (np.abs(speed) < 0.01)
        gain_wh = np.where(charging, c.charge_w * dt / 3600.0, 0.0)
        before = self.soc.copy()
        self.soc = np.clip(self.soc + (gain_wh - used_wh) / c.capacity_wh, 0.0, 1.0)
        crossed = np.flatnonzero((before >= c.low_threshold) & (self.soc < c.low_threshold))
        return crossed

    def charging_mask(self, xy: np.ndarray, speed: np.ndarray) -> np.ndarray:
        if not len(self.docks) or not len(self.soc):
            return np.zeros(len(self.soc), dtype=bool)
        d = np.min(np.linalg.norm(xy[:, None, :] - self.docks[None, :, :], axis=2), axis=1)
        return (d < self.config.dock_radius) & (np.abs(speed) < 0.01)
