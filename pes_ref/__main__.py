"""``python -m pes_ref``: the command line of :mod:`pes_ref.cli.main`."""
import sys

from pes_ref.cli import main

if __name__ == "__main__":
    sys.exit(main())
