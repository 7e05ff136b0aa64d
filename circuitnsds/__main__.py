"""``python -m circuitnsds`` is the ``circuitnsds`` command."""

import sys

from circuitnsds.cli.main import program

if __name__ == "__main__":  # sweeps start worker processes, which must not run the command again
    sys.exit(program())
