"""AMCL-style particle filter: odometry motion model, likelihood-field weights, KLD-adaptive resampling
with augmented-MCL random injection (Thrun et al., Probabilistic Robotics, Tables 5.6, 8.3, 8.4)."""

from __future__ import annotations

import math

import numpy as np

from sim.errors import ErrorCode, FleetError
from sim.transforms import wrap_angles
from slam import se2
from slam.likelihood_field import LikelihoodField


class ParticleFilter:
    def __init__(self, field: LikelihoodField, rng: np.random.Generator, *, min_particles: int = 200,
                 max_particles: int = 4000, kld_error: float = 0.02, kld_z: float = 2.326, bin_xy: float = 0.2,
                 bin_yaw: float = math.radians(10), alpha: tuple[float, float, float, float] = (0.05, 0.01, 0.05, 0.01),
                 alpha_slow: float = 0.002, alpha_fast: float = 0.1) -> None:
        self.field = field
        self.rng = rng
        self.min_particles, self.max_particles = min_particles, max_particles
        self.kld_error, self.kld_z = kld_error, kld_z
        self.bin_xy, self.bin_yaw = bin_xy, bin_yaw
        self.alpha = alpha
        self.alpha_slow, self.alpha_fast = alpha_slow, alpha_fast
        self.w_slow = self.w_fast = 0.0
        self.particles = np.zeros((0, 3))
        self.weights = np.zeros(0)
        self._fresh = np.zeros(0, dtype=bool)  # particles injected by the last resampling
        self.injected = 0

    # ---- initialisation ------------------------------------------------------------------------------

    def init_pose(self, pose: se2.PoseTuple, sigma_xy: float = 0.25, sigma_yaw: float = 0.2) -> None:
        n = self.max_particles // 2
        p = self.rng.normal(0.0, 1.0, (n, 3)) * np.array([sigma_xy, sigma_xy, sigma_yaw]) + np.array(pose)
        p[:, 2] = wrap_angles(p[:, 2])
        self._set(p)

    def init_global(self) -> None:
        """Uniform over the map's free cells (global localisation)."""
        self._set(self._random(self.max_particles))

    def _random(self, n: int) -> np.ndarray:
        free = self.field.free_cells
        if len(free) == 0:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "the map has no free cells to place particles in",
                             "load a map with explored free space")
        idx = self.rng.integers(0, len(free), n)
        jitter = self.rng.uniform(-0.5, 0.5, (n, 2)) * self.field.grid.resolution
        return np.column_stack([free[idx] + jitter, self.rng.uniform(-math.pi, math.pi, n)])

    def _set(self, particles: np.ndarray, fresh: int = 0) -> None:
        self.particles = particles
        self.weights = np.full(len(particles), 1.0 / len(particles))
        self._fresh = np.zeros(len(particles), dtype=bool)
        self._fresh[len(particles) - fresh:] = fresh > 0

    # ---- the filter ----------------------------------------------------------------------------------

    def predict(self, delta: se2.PoseTuple) -> None:
        """Sample the odometry motion model for a base_link motion `delta` (in the previous base frame)."""
        dx, dy, dth = delta
        trans = math.hypot(dx, dy)
        rot1 = math.atan2(dy, dx) if trans > 1e-3 else 0.0
        if abs(wrap_angles(np.array([rot1]))[0]) > math.pi / 2:  # driving backwards: same noise, no U-turn
            rot1 = float(wrap_angles(np.array([rot1 + math.pi]))[0])
            trans = -trans
        rot2 = float(wrap_angles(np.array([dth - rot1]))[0])
        a1, a2, a3, a4 = self.alpha
        n = len(self.particles)
        sd_r1 = math.sqrt(a1 * rot1**2 + a2 * trans**2)
        sd_t = math.sqrt(a3 * trans**2 + a4 * (rot1**2 + rot2**2))
        sd_r2 = math.sqrt(a1 * rot2**2 + a2 * trans**2)
        r1 = rot1 + self.rng.normal(0.0, 1.0, n) * sd_r1
        t = trans + self.rng.normal(0.0, 1.0, n) * sd_t
        r2 = rot2 + self.rng.normal(0.0, 1.0, n) * sd_r2
        p = self.particles
        heading = p[:, 2] + r1
        self.particles = np.column_stack([p[:, 0] + t * np.cos(heading), p[:, 1] + t * np.sin(heading),
                                          wrap_angles(heading + r2)])

    def update(self, points: np.ndarray) -> float:
        """Weight particles by the scan; returns the mean per-beam likelihood (for kidnap detection)."""
        ll = self.field.log_likelihood(self.particles, points)
        k = max(1, len(points))
        # Per-beam geometric-mean likelihood of each particle: comparable across scans and beam counts.
        per_beam = np.exp(ll / k)
        # Particles injected by the last resampling are left out: counting them would lower w_fast and
        # so trigger more injection, a loop that keeps a recovered filter diluted.
        old = ~self._fresh
        w_avg = float(np.sum(self.weights[old] * per_beam[old]) / max(1e-300, self.weights[old].sum())) \
            if old.any() else float(np.mean(per_beam))
        self.w_slow = w_avg if self.w_slow == 0 else self.w_slow + self.alpha_slow * (w_avg - self.w_slow)
        self.w_fast = w_avg if self.w_fast == 0 else self.w_fast + self.alpha_fast * (w_avg - self.w_fast)
        logw = np.log(np.maximum(self.weights, 1e-300)) + ll
        w = np.exp(logw - logw.max())
        self.weights = w / w.sum()
        return w_avg

    @property
    def p_inject(self) -> float:
        """Augmented MCL's injection probability: > 0 when recent scans fit worse than usual."""
        return max(0.0, 1.0 - self.w_fast / self.w_slow) if self.w_slow > 0 else 0.0

    def resample(self, hypotheses: np.ndarray | None = None) -> None:
        """KLD-adaptive resampling plus augmented-MCL injection: when the short-term likelihood falls
        below the long-term one, a share max(0, 1 − w_fast/w_slow) of the particle budget is drawn
        uniformly over the free space. The random particles come on top of the KLD set (not instead
        of it), so a kidnapped robot is searched for with the full budget while the old mode survives
        until the scans disprove it. `hypotheses` (k, 3), if given, seed 3/4 of the injected particles
        (a sensor-driven proposal, see slam.global_search); the rest stay uniform."""
        idx = self.rng.choice(len(self.particles), size=self.max_particles, p=self.weights)
        drawn = self.particles[idx]
        kept = drawn[: self._kld_count(drawn)]
        self.injected = min(round(self.p_inject * self.max_particles), self.max_particles - len(kept) // 2)
        if self.injected > 0:
            fresh = self._random(self.injected)
            if hypotheses is not None and len(hypotheses):
                m = 3 * self.injected // 4
                seeds = hypotheses[self.rng.integers(0, len(hypotheses), m)]
                fresh[:m] = seeds + self.rng.normal(0.0, 1.0, (m, 3)) * np.array([0.1, 0.1, 0.05])
                fresh[:m, 2] = wrap_angles(fresh[:m, 2])
            kept = np.vstack([kept[: self.max_particles - self.injected], fresh])
        self._set(kept, self.injected)

    def _kld_count(self, drawn: np.ndarray) -> int:
        """Smallest n such that the first n draws bound the KL error with k occupied bins (Fox 2003)."""
        bx = np.floor(drawn[:, 0] / self.bin_xy).astype(np.int64)
        by = np.floor(drawn[:, 1] / self.bin_xy).astype(np.int64)
        bt = np.floor(drawn[:, 2] / self.bin_yaw).astype(np.int64)
        key = (bx << 42) ^ (by << 21) ^ (bt & 0x1FFFFF)  # one int per bin: 1-D unique is much faster
        _, first = np.unique(key, return_index=True)
        is_new = np.zeros(len(drawn), dtype=bool)
        is_new[first] = True
        k = np.cumsum(is_new)  # distinct bins among the first n draws
        km1 = np.maximum(k - 1, 1).astype(np.float64)
        b = 2.0 / (9.0 * km1)
        need = km1 / (2.0 * self.kld_error) * (1.0 - b + np.sqrt(b) * self.kld_z) ** 3
        n = np.arange(1, len(drawn) + 1)
        ok = np.nonzero((n >= need) & (n >= self.min_particles))[0]
        return int(ok[0] + 1) if ok.size else len(drawn)

    # ---- reading -------------------------------------------------------------------------------------

    def mean(self) -> tuple[np.ndarray, np.ndarray]:
        """Weighted mean pose (circular mean for yaw) and 3×3 covariance."""
        w, p = self.weights, self.particles
        yaw = math.atan2(float(w @ np.sin(p[:, 2])), float(w @ np.cos(p[:, 2])))
        mu = np.array([w @ p[:, 0], w @ p[:, 1], yaw])
        d = p - mu
        d[:, 2] = wrap_angles(d[:, 2])
        return mu, (d * w[:, None]).T @ d

    def main_mode_share(self, radius: float = 0.5, yaw_tol: float = 0.5) -> float:
        """Weight share near the heaviest particle's neighbourhood: 1 for a single mode."""
        best = self.particles[int(np.argmax(self.weights))]
        d = self.particles - best
        near = (np.hypot(d[:, 0], d[:, 1]) < radius) & (np.abs(wrap_angles(d[:, 2])) < yaw_tol)
        return float(self.weights[near].sum())
