"""``python -m pes_ref``: the command line of :mod:`pes_ref.cli`."""
import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
