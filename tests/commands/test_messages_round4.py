"""Messages of issue 37, item 5: exact constants shown as decimals, the SOS proposer's refusal of
a sin/cos field says the exact validator recasts it, and a CasADi search that ran fewer starts
than asked says why."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import sympy as sp

import roa
from roa.proof._recast import _pretty, shown_coefficient
from roa.search._candidate import default_lyapunov


def test_exact_constants_print_as_decimals_small_rationals_stay():
    x = sp.Symbol("x")
    tenth = Fraction(0.1)  # 3602879701896397/36028797018963968
    assert tenth.denominator > 10**15
    text = _pretty({(2,): tenth, (0,): Fraction(1, 2)}, [x])
    assert "0.1*x**2" in text and "1/2" in text and "36028797018963968" not in text
    assert float(shown_coefficient(Fraction(1) / tenth)) == float(Fraction(1) / tenth)


def test_the_sos_proposer_on_a_sin_field_says_the_validator_recasts_it():
    from roa.search._sos import sos_level

    def field(t, x, xp):
        return (-x[1], xp.sin(x[0]) + (x[0] ** 2 - 1) * x[1])

    s = roa.System("sinvdp", field, (0.0, 0.0), ("x1", "x2"))
    res = sos_level(s, default_lyapunov(s))
    assert res.status is roa.SosStatus.NOT_POLYNOMIAL
    assert "exact SOS validator recasts sin, cos and rational terms" in res.message
    assert "after recasting half-integer powers" not in res.message


def test_fewer_casadi_starts_than_asked_are_explained():
    from roa.search._levelset_casadi import casadi_level
    from roa.systems.vanderpol import vanderpol

    s = vanderpol()
    V = default_lyapunov(s)
    res = casadi_level(s, V, np.asarray(V.P), n_starts=64, n_candidates=400)
    info = res.details
    assert info["n_starts"] == 64
    if info["n_run"] < info["n_starts"]:
        assert f"{info['n_run']} of the 64 starts ran" in info["starts_note"]
    else:
        assert "starts_note" not in info
    assert info["n_run"] < 64  # 400 directions in the plane: fewer than 64 well separated
