"""Map-aided particle filter on INS odometry (search-pattern paper §IV-E).

Its constraints implement the particles capability
(:mod:`firenav_framework.capabilities.particles`).
"""
from .estimator import ParticleFilter

PLUGINS = [ParticleFilter]

__all__ = ["ParticleFilter", "PLUGINS"]
