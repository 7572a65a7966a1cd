# The old home of the worker pools, kept so that earlier code still imports.
"""Process pools for independent simulations, now in :mod:`trainctl.run.pool`.

This module re-exports them under their old path (``from trainctl.parallel import
worker_pool``); new code imports from :mod:`trainctl.run.pool`.
"""

from __future__ import annotations

from trainctl.run.pool import available_cpus as available_cpus
from trainctl.run.pool import pool_size as pool_size
from trainctl.run.pool import process_pool as process_pool
from trainctl.run.pool import worker_pool as worker_pool
