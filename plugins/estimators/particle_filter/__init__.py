"""Map-aided particle filter on INS odometry (search-pattern paper §IV-E): the
``particle_filter`` estimator.

Modules: :mod:`.estimator` (the plugin), :mod:`.params`, :mod:`.initialisation` (initial
clouds), :mod:`.motion` (time update), :mod:`.stairs` (floor changes),
:mod:`.height` (floors against the INS's height), :mod:`.particles`
(summary, weights), :mod:`.resampling`, :mod:`.map_error` (§V-E monitor). Its
constraints implement the particles capability
(:mod:`firenav_framework.capabilities.particles`).
"""
from .estimator import ParticleFilterEstimator
from .params import ParticleFilterParams

__all__ = ["ParticleFilterEstimator", "ParticleFilterParams"]
