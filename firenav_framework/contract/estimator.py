"""The estimator role: measurements (or another estimator's output) to state estimates.

Contract of an :class:`Estimator`:

* Input: measurements and/or another estimator's output (INS odometry feeds the
  particle filter, the EKF and the collaborative graph), in time order, plus ticks if
  :meth:`~.component.Component.tick_period` asks for them.
* Output: :class:`~firenav_framework.messages.PoseEstimate` per firefighter with a
  covariance over (x, y, z, heading) that is consistent with the real error, a
  ``protection_radius`` and a ``trusted`` flag derived from them; and/or odometry for
  the next estimator. A pose is in the building frame once placed in the building, else
  in the estimator's own named frame (``"odometry"``).
* Constraints: an estimator lists in ``accepts`` the constraint capability bases
  (:mod:`firenav_framework.capabilities`) it calls; the validator refuses a constraint
  that is not an instance of one of them. Attached constraints are in
  ``self.constraints`` (in pipeline order) after construction.
* An estimator that finds its inputs contradicting each other (the plan, the odometry,
  the radio) says so with a diagnostic naming the place, and widens its uncertainty
  rather than holding on.
"""
from __future__ import annotations

from abc import abstractmethod
from typing import TYPE_CHECKING, ClassVar

from ..messages import Message
from .component import Component
from .context import Context
from .params import Params

if TYPE_CHECKING:
    from .constraint import Constraint

__all__ = ["Estimator"]


class Estimator(Component):
    """Turns measurements (or another estimator's output) into state estimates."""

    kind = "estimator"
    #: The constraint capability bases this estimator calls (see the module docstring).
    accepts: ClassVar[tuple[type["Constraint"], ...]] = ()

    def __init__(self, params: Params, ctx: Context):
        super().__init__(params, ctx)
        self.constraints: list[Constraint] = []

    @abstractmethod
    def handle(self, stream: str, msg: Message) -> None:
        """Process one message from input ``stream`` (in time order)."""
