"""Map-aided particle filter on INS odometry (search-pattern paper §IV-E).

The estimator (:mod:`.estimator`) and the "particles" capability its constraints
use (:mod:`.constraint`): constraints subclass :class:`ParticleConstraint`.
"""
from .constraint import ParticleConstraint, ParticleStep
from .estimator import ParticleFilter
from .particles import ParticleSummary, Particles

PLUGINS = [ParticleFilter]

__all__ = ["ParticleFilter", "ParticleConstraint", "ParticleStep", "Particles",
           "ParticleSummary", "PLUGINS"]
