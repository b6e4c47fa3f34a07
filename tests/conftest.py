"""Test-wide settings: proved certificates are remembered in a private cache, not the user's;
the slowest cases of parametrised tests run only with ``-m slow``."""

from __future__ import annotations

import os
import tempfile

import pytest

os.environ.setdefault("ROA_CACHE_DIR", tempfile.mkdtemp(prefix="roa-test-cache-"))


#: Cases of parametrised tests that run only with ``-m slow`` (the test's other cases stay in the
#: default suite; each is covered there by a faster case or by a benchmark).
SLOW_CASES = {
    "tests/proof/test_certificate_trust.py::test_tampered_certificates_are_refused[level 1e308]",
    "tests/nn/test_nn.py::test_pendulum_nn_certified_at_099_of_the_optimum_down_to_the_equilibrium"
    "[SYSTEM_RELU]",
    "tests/commands/test_cli_numbers_fuzz.py::test_a_numeric_option_gives_a_result_or_exit_2_naming_it"
    "[basin --grid]",
    "tests/commands/test_cli_numbers_fuzz.py::test_a_numeric_option_gives_a_result_or_exit_2_naming_it"
    "[certify --param]",
}


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Mark :data:`SLOW_CASES` slow before the ``-m`` selection reads the marks."""
    for item in items:
        if item.nodeid in SLOW_CASES:
            item.add_marker(pytest.mark.slow)
