"""What every command of the command line shares: exit codes and the one-line error."""
from __future__ import annotations

import sys

__all__ = ["EXIT_OK", "EXIT_FAIL", "EXIT_ERROR", "error"]

EXIT_OK = 0      #: success
EXIT_FAIL = 1    #: a check ran and failed (conformance --check), or a design went non-finite
EXIT_ERROR = 2   #: bad input: a refused case, an existing result, a usage error


def error(exc) -> int:
    """Print exactly one line ``error: <message>`` to stderr; return :data:`EXIT_ERROR`."""
    print("error: " + " ".join(str(exc).split()), file=sys.stderr)
    return EXIT_ERROR
