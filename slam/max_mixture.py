"""Max-mixture between factor for GTSAM Pose2 graphs (Olson & Agarwal 2012, "Inference on networks of
mixtures for robust robot mapping").

A scan match found by a wide search (no odometry to seed it) can be a wrong peak of an ambiguous score
surface: in a corridor the peak at the previous keyframe may outscore the truth 2 m further on (Radish
orebro, steps 27 and 117: edges with 1–2 cm σ that were 2 m wrong). A single Gaussian edge then holds the
wrong answer against every later loop closure. A max-mixture edge keeps alternatives: its likelihood is the
largest of its weighted Gaussian components, max_k w_k·N(e_k; 0, Σ_k), so the optimiser takes whichever
component fits the rest of the graph best at each linearisation. With a broad "null" component (a low
weight, a σ the size of the search window) it is a switchable edge: agreeing loop closures can override it.

Cost of component k (the negative log of its weighted density, up to a shared constant):
    ½·e_kᵀΣ_k⁻¹e_k + c_k,   c_k = ½·log det Σ_k − log w_k
The factor returns the whitened error of the best component plus one extra row √(2(c_k − c_min)), so
GTSAM's ½‖·‖² equals that cost minus c_min (≥ 0) and the extra row's Jacobian is zero.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import gtsam
import numpy as np
from pydantic import Field

from sim.config import StrictModel
from slam import se2


@dataclass(frozen=True, slots=True)
class Component:
    relative: se2.PoseTuple  # pose j in pose i's frame
    covariance: np.ndarray  # 3×3
    weight: float = 1.0


class MaxMixture:
    """The components' precomputed terms; `evaluate` is the factor's error function."""

    def __init__(self, i: int, j: int, components: Sequence[Component]) -> None:
        if not components:
            raise ValueError("a max-mixture needs at least one component")
        self.keys = (i, j)
        self.components = list(components)
        unit = gtsam.noiseModel.Unit.Create(3)
        self._between = [gtsam.BetweenFactorPose2(i, j, gtsam.Pose2(*c.relative), unit) for c in self.components]
        # R with RᵀR = Σ⁻¹ (whitening), and the constant of each component's negative log-density
        self._sqrt_info = [np.linalg.cholesky(np.linalg.inv(c.covariance)).T for c in self.components]
        consts = [0.5 * math.log(float(np.linalg.det(c.covariance))) - math.log(c.weight) for c in self.components]
        self._const = np.array(consts) - min(consts)

    def costs(self, values: gtsam.Values) -> np.ndarray:
        """½·Mahalanobis² + constant of every component at `values`."""
        out = np.empty(len(self.components))
        for k, (f, r) in enumerate(zip(self._between, self._sqrt_info, strict=True)):
            e = r @ np.asarray(f.unwhitenedError(values))
            out[k] = 0.5 * float(e @ e) + self._const[k]
        return out

    def active(self, values: gtsam.Values) -> int:
        """Index of the component that explains `values` best."""
        return int(np.argmin(self.costs(values)))

    def evaluate(self, _factor: object, values: gtsam.Values, jacobians: list[np.ndarray] | None) -> np.ndarray:
        k = self.active(values)
        f, r = self._between[k], self._sqrt_info[k]
        err = np.append(r @ np.asarray(f.unwhitenedError(values)), math.sqrt(2.0 * self._const[k]))
        if jacobians is not None:
            a, _ = f.linearize(values).jacobian()  # unit noise: the unwhitened [∂e/∂x_i  ∂e/∂x_j]
            zero = np.zeros((1, 3))
            jacobians[0] = np.vstack([r @ a[:, :3], zero])
            jacobians[1] = np.vstack([r @ a[:, 3:], zero])
        return err


def max_mixture_factor(i: int, j: int, components: Sequence[Component]) -> tuple[gtsam.CustomFactor, MaxMixture]:
    """A GTSAM factor between poses i and j whose likelihood is the max-mixture of `components`."""
    mix = MaxMixture(i, j, components)
    factor = gtsam.CustomFactor(gtsam.noiseModel.Unit.Create(4), gtsam.KeyVector([i, j]), mix.evaluate)
    return factor, mix


def switchable(relative: se2.PoseTuple, covariance: np.ndarray, null_sigma_xy: float,
               null_sigma_yaw: float, null_weight: float) -> list[Component]:
    """The match as the main component plus a broad null hypothesis centred on it: the edge holds unless
    the rest of the graph disagrees by several σ of the match, and then costs at most a bounded amount."""
    null = np.diag([null_sigma_xy ** 2, null_sigma_xy ** 2, null_sigma_yaw ** 2])
    return [Component(relative, covariance, 1.0), Component(relative, null, null_weight)]


class SwitchableConfig(StrictModel):
    """Edges of wide (no-odometry) matches as a max-mixture with a broad null component."""

    enabled: bool = Field(False, description="measured on orebro: no change (the loop groups' pull is spread "
                          "over the whole cycle, so no single edge leaves its main component)")
    null_sigma_xy: float = Field(2.5, gt=0, description="σ of the null component (about the wide window), m")
    null_sigma_yaw: float = Field(1.0, gt=0, description="rad")
    null_weight: float = Field(1e-3, gt=0, le=1, description="weight of the null component against the "
                               "match's 1: the lower, the more disagreement it takes to switch the edge off")
