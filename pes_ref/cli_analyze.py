"""The ``analyze`` command(s) of ``python -m pes_ref`` (registered with :func:`pes_ref.cli.command`)."""
from __future__ import annotations

from .cli import EXIT_ERROR, EXIT_OK, _error, command  # noqa: F401
