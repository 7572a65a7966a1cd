# Controllers: the protocol and the MPC family.
"""Controllers following one protocol (:class:`~trainctl.controllers.base.Controller`)."""

from trainctl.controllers.base import Controller as Controller
from trainctl.controllers.base import Measurement as Measurement
from trainctl.controllers.base import ReferencePreview as ReferencePreview
from trainctl.controllers.base import StepRecord as StepRecord

__all__ = ["Controller", "Measurement", "ReferencePreview", "StepRecord"]
