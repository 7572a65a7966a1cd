# Controllers: the controller protocol, the family conformance suite and the families.
"""Controllers following one protocol (:class:`~trainctl.controllers.base.Controller`).

:func:`check_family` checks a controller family (a built-in or a user's own)
against :class:`~trainctl.registry.ControllerFamily`.
"""

from trainctl.controllers.base import Controller as Controller
from trainctl.controllers.base import Measurement as Measurement
from trainctl.controllers.base import ReferencePreview as ReferencePreview
from trainctl.controllers.base import StepRecord as StepRecord
from trainctl.controllers.check import FamilyCheckError as FamilyCheckError
from trainctl.controllers.check import check_family as check_family

__all__ = ["Controller", "FamilyCheckError", "Measurement", "ReferencePreview", "StepRecord",
           "check_family"]
