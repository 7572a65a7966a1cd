# `python -m trainctl`: run the command-line interface.
"""Entry point for ``python -m trainctl``."""

from trainctl.cli.main import main

if __name__ == "__main__":
    raise SystemExit(main())
