"""The ``search_pattern_icp`` constraint: search-pattern pseudo-observations (§IV-D, §IV-E).

Every ``every_m`` metres walked (2 m, §V-B), once ``length_m`` (d = 20 m) of odometry
exists, the last d metres of the agent's INS track are compared with every search
pattern of the building (:class:`.comparison.PatternComparison`, Algorithm 1). Each
particle is then weighted by the likelihood of eq. (2),

    p_i = exp(-E^(i) / sigma^2),   sigma = 0.1 sqrt(m),

and the filter normalises (eq. 3). With ``resample_percent`` q > 0 (10 %, §V-B), the
q % lowest-weight particles are then replaced by pseudo-observations drawn in
proportion to the likelihood, with Gaussian noise of 0.5 m per axis and 25 deg on
the walking heading (§IV-E, §V-B). New particles that the noise would put outside
the free space (or on the other side of a wall from their node) are drawn again.
When no pseudo-observation particles are drawn at an update, eq. (2) reads only the
entries the particles are associated with, so ICP runs on their patterns alone (the
same figures as against every pattern; on a large floor most of the cost).

The paper resamples after every comparison and notes that this helps before the
filter has converged but can throw it off course in a larger area (§V-C, §V-D).
``resample_above_m2`` > 0 resamples only while the cloud's var_x + var_y exceeds it:
before convergence and after a disturbance such as a map error (§V-E).

The odometry trajectory is resampled every ``point_spacing_m`` along its path rather
than taken at 2 Hz as in the paper, so that the many pauses of a search (sweeping,
checking a door) do not pile points on one spot and bias the ICP fit.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
import shapely

from firenav_framework import Angle, PerAgent, Params, param
from firenav_framework.building.search_patterns import extract_search_patterns
from firenav_framework.capabilities.particles import ParticleConstraint, Particles, ParticleStep

from .comparison import Observations, PatternComparison

__all__ = ["SearchPatternIcpConstraint"]


class SearchPatternIcpParams(Params):
    length_m: float = param(20.0, unit="m", gt=0)
    """pattern length d (§V-B)"""
    every_m: float = param(2.0, unit="m", gt=0)
    """compare each time this far has been walked (§V-B)"""
    grid_spacing_m: float = param(1.0, unit="m", gt=0)
    """search-pattern grid spacing (§V-B)"""
    sigma: float = param(0.1, unit="sqrt(m)", gt=0)
    """sigma of the likelihood eq. (2)"""
    resample_percent: float = param(10.0, unit="%", ge=0, le=100)
    """q: share of lowest-weight particles replaced by pseudo-observations after each comparison (0
    = off)"""
    resample_above_m2: float = param(0.0, unit="m^2", ge=0)
    """resample from pseudo-observations only while the cloud's var_x + var_y exceeds this, i.e.
    while the filter has not converged (0: always, the paper)"""
    resample_position_sigma_m: float = param(0.5, unit="m", ge=0)
    """noise on resampled positions (§V-B)"""
    resample_heading_sigma: Angle = param(math.radians(25.0), unit="rad", ge=0)
    """noise on resampled walking headings (25 deg, §V-B)"""
    point_spacing_m: float = param(0.5, unit="m", gt=0)
    """odometry resampled along its path at this spacing"""
    right_hand_heading: Literal["arrival", "departure"] = param("arrival")
    """walking direction of a right-hand observation: the direction of arrival at the pattern's
    last node, or the paper's Hea(eta, 2), the next step (see comparison.py)"""
    icp_iterations: int = param(30, gt=0)
    """ICP iteration limit"""
    icp_tolerance: float = param(1e-4, unit="m", gt=0)
    """ICP stops when an iteration improves the RMSE by less"""


@dataclass
class _AgentState:
    next_at_m: float
    obs: Observations | None = None
    obs_t: float = math.nan


class SearchPatternIcpConstraint(ParticleConstraint):
    """Search-pattern ICP pseudo-observations: weight (and optionally resample) particles."""

    name = "search_pattern_icp"
    needs_building = True
    Params = SearchPatternIcpParams

    def __init__(self, params: SearchPatternIcpParams, ctx):
        super().__init__(params, ctx)
        if params.every_m > params.length_m:
            raise ValueError("every_m must not exceed length_m")
        self.history_m = params.length_m
        self._comparison: PatternComparison | None = None
        self.state: PerAgent[_AgentState] = PerAgent(lambda a: _AgentState(params.length_m))

    @property
    def comparison(self) -> PatternComparison:
        """The building's sub-patterns (extracted on first use, shared by all agents)."""
        if self._comparison is None:
            p = self.params
            patterns = extract_search_patterns(self.ctx.building, spacing=p.grid_spacing_m)
            for note in patterns.notes:
                self.ctx.log.info("search patterns: %s", note)
            self._comparison = PatternComparison(patterns, p.length_m, max_iter=p.icp_iterations,
                                                 tol=p.icp_tolerance,
                                                 right_hand_heading=p.right_hand_heading)
        return self._comparison

    def start(self) -> None:
        self.comparison  # noqa: B018 - extract the patterns before the first message

    def reset(self, agent: str) -> None:
        self.state.reset(agent)

    def log_likelihood(self, step: ParticleStep) -> np.ndarray | None:
        st = self.state[step.agent]
        walked = step.history.walked_m
        if walked < st.next_at_m:
            return None
        st.next_at_m = walked + self.params.every_m
        xy = step.history.tail(self.params.length_m, self.params.point_spacing_m)
        if xy is None:
            return None
        p = step.particles
        comparison = self.comparison
        entries = comparison.entries_of(p.xy, step.walking_heading(), p.floor)
        obs = None
        if not self._resamples(step):
            # only the particles' own entries are read: ICP on their patterns alone
            obs = comparison.compare(xy, np.unique(entries[entries >= 0] // 2))
            if not np.isfinite(comparison.rmse_of(obs, entries)).any():
                obs = None      # whether any pattern matches at all needs them all
        if obs is None:
            obs = comparison.compare(xy)
        self.ctx.count("comparisons")
        if not obs.any_finite:
            self.ctx.count("comparisons_without_match")
            return None
        st.obs, st.obs_t = obs, step.t
        e = comparison.rmse_of(obs, entries)
        ll = -e / self.params.sigma ** 2
        if np.isnan(ll).any():  # particles on floors without patterns: as likely as the best
            ll[np.isnan(ll)] = np.nanmax(ll) if np.isfinite(np.nanmax(ll, initial=-np.inf)) else 0.0
        return ll

    def _resamples(self, step: ParticleStep) -> bool:
        """Whether this update draws pseudo-observation particles (from every pattern)."""
        return self.params.resample_percent > 0 and step.spread_m2 > self.params.resample_above_m2

    def replacements(self, step: ParticleStep) -> Particles | None:
        st = self.state[step.agent]
        q = self.params.resample_percent
        if q <= 0 or st.obs is None or st.obs_t != step.t:
            return None
        if not self._resamples(step):
            self.ctx.count("resampling_skipped_converged")
            return None
        n = int(round(len(step.particles) * q / 100))
        if n == 0:
            return None
        obs, rng = st.obs, step.rng
        idx = self.comparison.sample(obs, n, self.params.sigma, rng)
        xy = obs.position[idx] + rng.standard_normal((n, 2)) * self.params.resample_position_sigma_m
        self._keep_reachable(xy, obs.position[idx], obs.floor[idx], step.building, rng)
        heading = obs.heading[idx] + rng.standard_normal(n) * self.params.resample_heading_sigma
        donors = rng.integers(0, len(step.particles), n)   # step scale, yaw rate: the cloud's
        self.ctx.count("pseudo_observation_particles", n)
        return Particles.create(xy, step.frame_yaw_for(heading), obs.floor[idx],
                                step.particles.scale[donors], step.particles.yaw_rate[donors])

    def _keep_reachable(self, xy: np.ndarray, node: np.ndarray, floor: np.ndarray, building,
                        rng: np.random.Generator, tries: int = 5) -> None:
        """Redraw noisy positions that left the free space or crossed a wall from their node."""
        sigma = self.params.resample_position_sigma_m
        for fl in np.unique(floor):
            f = building.floors[int(fl)]
            sel = np.flatnonzero(floor == fl)

            def bad() -> np.ndarray:
                p = xy[sel]
                return (~shapely.contains_xy(f.free_space, p[:, 0], p[:, 1])
                        | f.crosses_wall(node[sel], p))

            for _ in range(tries):
                redo = sel[bad()]
                if not len(redo):
                    break
                xy[redo] = node[redo] + rng.standard_normal((len(redo), 2)) * sigma
            else:
                redo = sel[bad()]
                xy[redo] = node[redo]
