"""Sensor stream health: measured rate vs configured, latency, dropouts, noise level, a 0–1 quality, alerts.

All times are sim time. A stream is fed (stamp, receive time, values); `report(now)` evaluates it over a
sliding window. A dropout is a gap longer than `dropout_factor` periods; an ongoing silence is flagged as
soon as it is longer than that, so a 10 Hz lidar that stops is flagged 0.3 s later with the default 3×.
Noise is the white-noise σ estimated from consecutive samples: 1.4826·MAD(Δvalues)/√2, robust to the
few large differences a moving robot makes (for a lidar it is the scan-to-scan noise when stationary).
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from sim.perception.types import HealthAlert, StreamConfig, StreamHealth


class StreamMonitor:
    def __init__(self, name: str, *, rate_hz: float, dropout_factor: float = 3.0, window_s: float = 2.0,
                 max_latency: float = 0.1, nominal_noise: float | None = None, noise_factor: float = 2.0,
                 min_rate_ratio: float = 0.8) -> None:
        self.name = name
        self.rate_hz = rate_hz
        self.period = 1.0 / rate_hz
        self.gap_limit = dropout_factor * self.period
        self.window = window_s
        self.max_latency = max_latency
        self.nominal_noise = nominal_noise
        self.noise_factor = noise_factor
        self.min_rate_ratio = min_rate_ratio
        self._intervals: deque[tuple[float, float]] = deque()  # (stamp, time since the previous one)
        self._latencies: deque[tuple[float, float]] = deque()
        self._diffs: deque[tuple[float, np.ndarray]] = deque()
        self._gaps: deque[tuple[float, float]] = deque()  # (stamp that ended it, length), closed dropouts
        self._dropouts = 0
        self._longest_gap = 0.0
        self._first: float | None = None
        self._last: float | None = None
        self._last_values: np.ndarray | None = None

    def observe(self, stamp: float, received: float | None = None, values: np.ndarray | None = None) -> None:
        """Record one reading: its stamp, when it arrived (default: at its stamp) and a value vector."""
        if self._last is not None:
            gap = stamp - self._last
            self._intervals.append((stamp, gap))
            self._longest_gap = max(self._longest_gap, gap)
            if gap > self.gap_limit:
                self._dropouts += 1
                self._gaps.append((stamp, gap))
        self._first = stamp if self._first is None else self._first
        self._last = stamp
        self._latencies.append((stamp, (received if received is not None else stamp) - stamp))
        if values is not None:
            v = np.asarray(values, dtype=float).ravel()
            prev = self._last_values
            if prev is not None and prev.shape == v.shape:
                d = v - prev
                d = d[np.isfinite(d)]
                if d.size:
                    self._diffs.append((stamp, d))
            self._last_values = v
        self._trim(stamp)

    def _trim(self, now: float) -> None:
        start = now - self.window
        while self._intervals and self._intervals[0][0] < start:
            self._intervals.popleft()
        while self._latencies and self._latencies[0][0] < start:
            self._latencies.popleft()
        while self._gaps and self._gaps[0][0] < start:
            self._gaps.popleft()
        while self._diffs and self._diffs[0][0] < start:
            self._diffs.popleft()

    def report(self, now: float) -> StreamHealth:
        self._trim(now)
        silent = math.inf if self._last is None else max(0.0, now - self._last)
        measured = self._measured_rate(now)
        lat = [x for _, x in self._latencies]
        lat_mean = float(np.mean(lat)) if lat else 0.0
        lat_max = float(np.max(lat)) if lat else 0.0
        noise = self._noise()
        active = silent > self.gap_limit
        alerts = self._alerts(now, silent, measured, lat_mean, noise, active)
        quality = self._quality(measured, lat_mean, noise, active)
        return StreamHealth(self.name, now, self.rate_hz, measured, lat_mean, lat_max,
                            self._dropouts + (1 if active and self._last is not None else 0),
                            max(self._longest_gap, silent if self._last is not None else 0.0),
                            silent, noise, quality, tuple(alerts))

    def _measured_rate(self, now: float) -> float:
        """Intervals ending in the window over their total length (a gap that began before the window
        counts whole); an ongoing silence longer than a period lengthens the span."""
        if not self._intervals or self._last is None:
            return 0.0
        span = sum(g for _, g in self._intervals) + max(0.0, now - self._last - self.period)
        return len(self._intervals) / span if span > 0 else 0.0

    def _noise(self) -> float | None:
        if len(self._diffs) < 3:
            return None
        d = np.concatenate([x for _, x in self._diffs])
        mad = float(np.median(np.abs(d - np.median(d))))
        return 1.4826 * mad / math.sqrt(2.0)

    def _alerts(self, now: float, silent: float, measured: float, latency: float, noise: float | None,
                active: bool) -> list[HealthAlert]:
        out: list[HealthAlert] = []
        if self._last is None:
            if now > self.gap_limit:
                out.append(HealthAlert(self.name, "no_data", f"no reading in {now:.2f} s", now))
            return out
        if active:
            out.append(HealthAlert(self.name, "dropout",
                                   f"silent for {silent:.2f} s (> {self.gap_limit:.2f} s)", now))
        elif self._first is not None and now - self._first >= self.window:
            if measured < self.min_rate_ratio * self.rate_hz:
                out.append(HealthAlert(self.name, "rate_low",
                                       f"{measured:.1f} Hz, configured {self.rate_hz:.1f} Hz", now))
            elif measured > self.rate_hz / self.min_rate_ratio:
                out.append(HealthAlert(self.name, "rate_high",
                                       f"{measured:.1f} Hz, configured {self.rate_hz:.1f} Hz", now))
        if latency > self.max_latency:
            out.append(HealthAlert(self.name, "latency", f"mean latency {latency * 1e3:.0f} ms", now))
        if noise is not None and self.nominal_noise and noise > self.noise_factor * self.nominal_noise:
            out.append(HealthAlert(self.name, "noise",
                                   f"noise σ {noise:.4g}, nominal {self.nominal_noise:.4g}", now))
        return out

    def _quality(self, measured: float, latency: float, noise: float | None, active: bool) -> float:
        if active or self._last is None:
            return 0.0
        q = min(1.0, measured / self.rate_hz) if self._intervals else 0.5
        q /= 1.0 + len(self._gaps)  # each recent dropout halves, thirds, ... the score
        if latency > self.max_latency > 0:
            q *= self.max_latency / latency
        if noise is not None and self.nominal_noise and noise > self.nominal_noise:
            q *= self.nominal_noise / noise
        return float(min(1.0, max(0.0, q)))


def make_stream_monitor(name: str, config: StreamConfig) -> StreamMonitor:
    return StreamMonitor(name, **config.model_dump())
