"""The protocols between estimators and their constraints, as types no plugin owns.

A *capability* is an abstract constraint base class: the methods an estimator calls on
the constraints attached to it, and the data it hands them. An estimator lists the
capabilities it calls in ``accepts``; a constraint subclasses one; the validator
refuses a constraint attached to an estimator that does not accept its capability.

=========================================  ===============================  ==================
capability                                 estimator calls                  built-in hosts
=========================================  ===============================  ==================
:class:`.particles.ParticleConstraint`     ``log_likelihood(ParticleStep)``  particle_filter
                                           ``replacements(ParticleStep)``
:class:`.odometry_correction.              ``correct(OdometryStep)``         dead_reckoning
OdometryCorrection`
=========================================  ===============================  ==================

A new capability is a module here with a ``Constraint`` subclass declared with
``capability=True`` and its abstract methods; estimators and constraints in any package
import it from here.
"""
from .odometry_correction import OdometryCorrection, OdometryStep, StepCorrection
from .odometry_history import OdometryHistory
from .particles import ParticleConstraint, Particles, ParticleStep

__all__ = ["OdometryCorrection", "OdometryStep", "StepCorrection", "OdometryHistory",
           "ParticleConstraint", "Particles", "ParticleStep"]
