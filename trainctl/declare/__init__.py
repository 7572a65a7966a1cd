# Declarations: value rules, file keys, limits, violations, validated JSON.
"""The declaration machinery shared by scenario files, models and saved files.

:mod:`~trainctl.declare.constraints` holds the value rules, :mod:`~trainctl.declare.keys`
the key declarations (file key, unit and converter to SI, default, doc),
:mod:`~trainctl.declare.limits` the physical limits, :mod:`~trainctl.declare.violations`
the located violations and :mod:`~trainctl.declare.jsonfile` JSON files read against a
declared model.
"""

from __future__ import annotations

from trainctl.declare.keys import Alt as Alt
from trainctl.declare.keys import Key as Key
from trainctl.declare.keys import check_fields as check_fields
from trainctl.declare.keys import declared_fields as declared_fields
from trainctl.declare.keys import first_error as first_error
from trainctl.declare.keys import python_error as python_error
from trainctl.declare.keys import render_refs as render_refs
from trainctl.declare.keys import settings as settings

__all__ = [
    'Alt', 'Key', 'check_fields', 'declared_fields', 'first_error', 'python_error',
    'render_refs', 'settings',
]
