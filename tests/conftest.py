"""Test-wide settings: proved certificates are remembered in a private cache, not the user's;
the slowest cases of parametrised tests run only with ``-m slow``."""

from __future__ import annotations

import os
import tempfile

import pytest

os.environ.setdefault("ROA_CACHE_DIR", tempfile.mkdtemp(prefix="roa-test-cache-"))


#: Tests and cases of parametrised tests that run only with ``-m slow`` (each is covered in the
#: default suite by a faster test or case, by a benchmark, or by the README's main command).
SLOW_CASES = {
    "tests/proof/test_certificate_trust.py::test_tampered_certificates_are_refused[level 1e308]",
    "tests/nn/test_nn.py::test_pendulum_nn_certified_at_099_of_the_optimum_down_to_the_equilibrium"
    "[SYSTEM_RELU]",
    "tests/commands/test_cli_numbers_fuzz.py::test_a_numeric_option_gives_a_result_or_exit_2_naming_it"
    "[basin --grid]",
    "tests/commands/test_cli_numbers_fuzz.py::test_a_numeric_option_gives_a_result_or_exit_2_naming_it"
    "[certify --param]",
    "tests/commands/test_cli_numbers_fuzz.py::test_a_numeric_option_gives_a_result_or_exit_2_naming_it"
    "[basin --samples]",
    "tests/proof/test_sos_combinations.py::test_every_pattern_on_a_recast_field_and_a_parameter_box"
    "[sdsos]",
    "tests/certification/test_robust.py::test_wide_box_certified_below_and_refuted_above_the_worst_case",
    "tests/search/test_sos_symmetry.py::test_the_split_recast_program_has_the_unsplit_optimum"
    "[examples/systems/quadrotor2d.py:SYSTEM-0.12]",
    "tests/integration/test_generated_kernels.py::test_vanderpol_generated_kernel_matches_numpy",
    "tests/montecarlo/test_certified_share.py::"
    "test_box_share_counts_independently_and_estimates_the_area_ratio",
    "tests/search/test_box_lyapunov.py::test_cli_robust_vanderpol_without_v",
    # degree 4 on every polynomial route and the quadratic V on the recast routes stay default
    "tests/proof/test_sos_combinations.py::test_degree_4_V_on_a_recast_field[sdsos]",
    # the reader of every numeric option is exercised by the faster options' cases
    "tests/commands/test_cli_numbers_fuzz.py::test_a_numeric_option_gives_a_result_or_exit_2_naming_it"
    "[certify --level]",
    "tests/commands/test_cli_numbers_fuzz.py::test_a_numeric_option_gives_a_result_or_exit_2_naming_it"
    "[certify --check-above]",
    # the terminal set from the committed certificate: also in
    # test_basin_runs_with_the_certified_set_keep_their_statuses; refusals in test_terminal_set.py
    "ipc_paper/tests/test_terminal_fastpath.py::test_the_certified_terminal_set_of_the_reproduction",
    # two of the eight kinds of users' systems whose reference is a multistart (pendulum and
    # rational stay default; Van der Pol's published level is checked by the example gallery)
    *(
        f"tests/commands/test_user_systems.py::{test}[{kind}]"
        for test in (
            "test_default_lyapunov_is_the_files_or_the_lyapunov_equation",
            "test_level_search_matches_the_reference",
            "test_certify_below_and_refute_above",
        )
        for kind in ("poly2d", "vanderpol")
    ),
    # a box of several parameters: test_worst_case_inside_the_box_with_three_parameters
    "tests/proof/test_sos_robust.py::test_two_parameter_polynomial_box",
    # a near-diagonal (seed 0) and a general form (seed 1) stay default
    "tests/proof/test_contract.py::test_contracted_boxes_keep_every_point_of_the_sublevel_set[2]",
    "tests/proof/test_contract.py::test_contracted_boxes_keep_every_point_of_the_sublevel_set[3]",
    # compiles the hybrid-coordinate kernels; the plain and flat terminal sets stay default
    "ipc_paper/tests/test_terminal_fastpath.py::test_fast_path_is_bit_identical_to_the_public_protocol"
    "[hybrid]",
    # the closed forms (a real spectrum, a complex pair) of kappa stay default
    "tests/search/test_conditioned.py::test_against_a_direct_minimisation",
    # the split program's optimum and exact check: test_the_split_program_has_the_unsplit_optimum_*
    "tests/search/test_sos_symmetry.py::test_the_split_recast_program_has_the_unsplit_optimum"
    "[examples/systems/pendulum.py:SYSTEM-9.0]",
}


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Mark :data:`SLOW_CASES` slow before the ``-m`` selection reads the marks."""
    for item in items:
        if item.nodeid in SLOW_CASES:
            item.add_marker(pytest.mark.slow)
