"""Extension template for a firenav CONSTRAINT: knowledge an estimator applies.

How to use it:

1. Copy this file into your package and rename the class ``<Rule>Constraint``; work
   through the ``TODO`` markers. Choose the capability your estimator calls from
   ``firenav_framework.capabilities`` (``ParticleConstraint`` for the particle filter,
   ``OdometryCorrection`` for dead reckoning) and subclass it.
2. Register it: ``"constraint.my_speed_limit" = "acme_firenav.constraint:MyConstraint"``.
3. Test it with ``firenav_framework.testing.check_plugin(MyConstraint)``: the suite
   attaches it to a registered estimator that accepts its capability.

As it is, the class is a working example for the particle filter: particles that would
have moved faster than a person walks are down-weighted. It passes ``check_plugin``.

The contract (``firenav_framework/contract/constraint.py`` and the capability's module):

* Attached under an estimator in the pipeline; it implements the capability's methods
  the estimator calls (here ``log_likelihood``) and never imports an estimator module.
* It may read streams of its own (``inputs``, e.g. UWB ranges): then it implements
  ``handle``.
* Per-firefighter state of its own, forgotten by ``reset(agent)``.
* Answers never contain NaN: ``-inf`` removes a particle, ``None`` means "no
  information this step".
"""
from __future__ import annotations

import numpy as np

from firenav_framework import Params, param
from firenav_framework.capabilities import ParticleConstraint, ParticleStep


class MyConstraint(ParticleConstraint):
    """Speed limit: particles that moved faster than a firefighter walks lose weight."""

    # TODO: the name pipelines use; unique among constraints.
    name = "my_speed_limit"
    # TODO: True if it reads ctx.building (the validator then requires a building).
    needs_building = False

    class Params(Params):
        # TODO: your parameters, with units and descriptions.
        max_speed: float = param(2.5, unit="m/s", gt=0)
        """fastest a firefighter moves inside a building"""
        sigma: float = param(0.5, unit="m/s", gt=0)
        """how sharply faster particles lose weight (1 sigma of the excess speed)"""

    def log_likelihood(self, step: ParticleStep) -> np.ndarray | None:
        # TODO: your rule. (N,) log-weight increments for step.particles, or None.
        dt = float(step.odometry.t - step.odometry.t_start)
        if not dt > 0:
            self.ctx.count("steps_without_duration")
            return None
        moved = np.hypot(*(step.particles.xy - step.before.xy).T)
        excess = np.maximum(moved / dt - self.params.max_speed, 0.0)
        return -0.5 * (excess / self.params.sigma) ** 2

    def reset(self, agent: str) -> None:
        # TODO: forget this firefighter's state (this example keeps none).
        pass
