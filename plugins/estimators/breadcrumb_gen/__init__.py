"""Breadcrumb collaborative localisation: the relative measurement graph as a
generalized electrical network (GEN/RMG), after Li et al., "An Automatic and Accurate
Localization System for Firefighters" (``../shared/papers/breadcrumb-gen-rmg.txt``)."""
from __future__ import annotations

from .batch import KirchhoffSystem, batch_blue
from .estimator import BreadcrumbGen
from .network import GeneralizedElectricalNetwork

PLUGINS = [BreadcrumbGen]

__all__ = ["BreadcrumbGen", "GeneralizedElectricalNetwork", "KirchhoffSystem", "batch_blue",
           "PLUGINS"]
