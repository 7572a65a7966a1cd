# The old home of seed 003's consensus synthesis, kept so that earlier code still imports.
"""Seed 003's consensus loop and gain synthesis, now in :mod:`trainctl.controllers.hinf.synthesis`.

This module re-exports them under their old path (``from trainctl.analysis.consensus_hinf
import consensus_loop``); new code imports from the H∞ family.
"""

from __future__ import annotations

from trainctl.controllers.hinf.synthesis import CHANNEL_GROUPS as CHANNEL_GROUPS
from trainctl.controllers.hinf.synthesis import DEFAULT_SCALING as DEFAULT_SCALING
from trainctl.controllers.hinf.synthesis import OUTPUTS as OUTPUTS
from trainctl.controllers.hinf.synthesis import OWN_SPEEDS as OWN_SPEEDS
from trainctl.controllers.hinf.synthesis import PADE_POINTS as PADE_POINTS
from trainctl.controllers.hinf.synthesis import Certificate as Certificate
from trainctl.controllers.hinf.synthesis import ConsensusLoop as ConsensusLoop
from trainctl.controllers.hinf.synthesis import GainSynthesis as GainSynthesis
from trainctl.controllers.hinf.synthesis import certify_gains as certify_gains
from trainctl.controllers.hinf.synthesis import consensus_loop as consensus_loop
from trainctl.controllers.hinf.synthesis import synthesise_gains as synthesise_gains
