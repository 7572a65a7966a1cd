# The trainctl command.
"""The ``trainctl`` command (:func:`main`); the subcommands live in :mod:`~trainctl.cli.main`."""

from __future__ import annotations

from trainctl.cli.main import main as main

__all__ = ["main"]
