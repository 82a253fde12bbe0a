"""The constraint role: knowledge an estimator applies (walls, doors, search patterns ...).

Contract of a :class:`Constraint`:

* It is attached under an estimator in the pipeline and speaks that estimator's
  language: it subclasses a *capability* base from :mod:`firenav_framework.capabilities`
  (e.g. :class:`~firenav_framework.capabilities.particles.ParticleConstraint`), which
  declares, as abstract methods, what the estimator calls and with what. The estimator
  lists the capabilities it accepts; the validator checks the pairing before anything
  runs. A constraint never imports an estimator's module.
* It may also read streams of its own (``inputs``, e.g. UWB ranges), delivered through
  :meth:`Constraint.handle` in time order with everything else; a constraint with
  inputs must override ``handle``.
* It keeps per-firefighter state of its own and forgets one firefighter in ``reset``.
"""
from __future__ import annotations

from typing import ClassVar

from ..messages import Message
from .component import Component

__all__ = ["Constraint"]


class Constraint(Component):
    """Knowledge an estimator can apply (walls, doors, search patterns, ...)."""

    kind = "constraint"
    #: The capability base this constraint implements (set by the capability base class).
    capability: ClassVar[type["Constraint"] | None] = None
    #: The methods of the capability its estimator calls; a constraint overrides at
    #: least one (the abstract ones always).
    hooks: ClassVar[tuple[str, ...]] = ()

    def __init_subclass__(cls, *, capability: bool = False, **kw: object) -> None:
        """``class X(Constraint, capability=True)`` declares X a capability base."""
        super().__init_subclass__(**kw)
        if capability:
            cls.capability = cls

    def handle(self, stream: str, msg: Message) -> None:
        """Process one message of the constraint's own ``inputs`` (in time order)."""
        raise NotImplementedError(f"{type(self).__name__} declares inputs but no handle()")
