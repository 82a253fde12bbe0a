"""Breadcrumb collaborative localisation: the relative measurement graph as a
generalized electrical network (GEN/RMG), after Li et al., "An Automatic and Accurate
Localization System for Firefighters" (``../shared/papers/breadcrumb-gen-rmg.txt``):
the ``breadcrumb_gen`` estimator.

Modules: :mod:`.estimator` (the plugin), :mod:`.params`, :mod:`.network` (the GEN),
:mod:`.incremental` (its solver), :mod:`.batch` (the batch BLUE it is checked against),
:mod:`.measurements` (measurement models and their linearisation).
"""
from __future__ import annotations

from .batch import KirchhoffSystem, batch_blue
from .estimator import BreadcrumbGenEstimator
from .network import GeneralizedElectricalNetwork
from .params import BreadcrumbGenParams

__all__ = ["BreadcrumbGenEstimator", "BreadcrumbGenParams", "GeneralizedElectricalNetwork",
           "KirchhoffSystem", "batch_blue"]
