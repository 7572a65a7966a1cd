# Controllers: the protocol and the MPC family.
"""Controllers following one protocol (:class:`~trainctl.controllers.base.Controller`)."""

from .base import Controller as Controller
from .base import Measurement as Measurement
from .base import ReferencePreview as ReferencePreview
from .base import StepRecord as StepRecord

__all__ = ["Controller", "Measurement", "ReferencePreview", "StepRecord"]
