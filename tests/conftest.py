"""Strict test configuration: deterministic hypothesis, floating-point errors raise."""
import os
import signal

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

# Deterministic by default: the same examples on every run and every machine.
settings.register_profile(
    "default", derandomize=True, max_examples=200, deadline=None, print_blob=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
# More examples, random seeds: `make test-thorough`.
settings.register_profile(
    "thorough", derandomize=False, max_examples=2000, deadline=None, print_blob=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))

# A suite started in the background of a non-interactive shell inherits SIGINT ignored, and so
# would every process it starts; the tests of Ctrl-C need it delivered, as at a terminal.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture(autouse=True)
def _strict_floats():
    """Overflow, invalid operations and division by zero raise instead of warning."""
    with np.errstate(over="raise", invalid="raise", divide="raise", under="ignore"):
        yield
