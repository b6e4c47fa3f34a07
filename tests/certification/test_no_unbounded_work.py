"""No unbounded work (issue item 4): a given level above the optimum in more states than the
branch and bound covers is refuted by the level search's witness before the branch and bound
runs, that branch and bound has a default time budget, and levels that overflow double precision
are refused before any program is built.

The ring (``examples/systems/ring.py``, V = |x|^2): ``x = e_1`` has ``V' = 0`` at ``V = 1`` and the
optimum is 0.9323 (the ladder's multistart SLSQP), so 0.95 is above it and the witness found
(a local minimum of V on ``{V' >= 0}``, 50 digits) lies at ``V`` in [0.93, 0.935].
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import pytest

import roa
from roa.cli import main
from roa.errors import RoaInputError
from roa.options import BNB_SECONDS, BNB_SECONDS_BACKUP
from roa.systems.vanderpol import vanderpol

sys.path.insert(0, str(Path(__file__).parents[2] / "examples" / "systems"))
from ring import ring  # noqa: E402

sys.path.pop(0)


def _witness_level(cert: roa.Certificate) -> float:
    return float(cert.validation.witness_check["V"])


def test_ring_8_above_its_optimum_is_refuted_by_the_witness_before_the_branch_and_bound():
    t0 = time.perf_counter()
    cert = roa.certify(ring(8), level=0.95)
    assert cert.status is roa.Verdict.REFUTED, cert.message
    assert cert.validation.meta["method"] == "witness search"
    assert cert.validation.boxes == 0  # no box of a branch and bound
    assert 0.93 <= _witness_level(cert) <= 0.935
    assert time.perf_counter() - t0 < 60


@pytest.mark.slow
def test_ring_20_above_its_optimum_is_refuted_within_a_minute(capsys):
    here = Path(__file__).parents[2] / "examples" / "systems" / "ring.py"
    t0 = time.perf_counter()
    code = main(["certify", "--system", f"{here}:SYSTEM_20", "--level", "0.95"])
    seconds = time.perf_counter() - t0
    out = capsys.readouterr().out
    assert code == 1 and "refuted: level 0.95, by witness search" in out, out
    assert seconds < 60


def test_the_backup_branch_and_bound_has_a_default_time_budget(monkeypatch):
    """Above the branch and bound's dimension, with the SOS route and the witness search
    failing, the branch and bound runs with BNB_SECONDS_BACKUP (300 s) unless a time limit is
    given; elsewhere BNB_SECONDS (3600 s)."""
    from roa.certification import _strategies as strategies
    from roa.proof._validation import Validation

    seen = []

    def fake(system, V, level, **kw):
        seen.append(kw["time_limit"])
        return Validation(roa.Verdict.INCONCLUSIVE, level, 0, 0.0, message="not run")

    monkeypatch.setattr(strategies, "validate_level", fake)
    auto = roa.AutoValidator(witness_search=False)
    auto.check(ring(8), roa.default_lyapunov(ring(8)), 0.95)  # SOS fails above the optimum
    given = roa.AutoValidator(roa.IntervalOptions(time_limit=7.0), witness_search=False)
    given.check(ring(8), roa.default_lyapunov(ring(8)), 0.95)
    roa.IntervalValidator().check(vanderpol(), roa.default_lyapunov(vanderpol()), 2.3)
    assert seen == [BNB_SECONDS_BACKUP, 7.0, BNB_SECONDS]


def test_an_overflowing_level_is_refused_before_any_program(capsys, monkeypatch):
    """Van der Pol's V' has a cubic term: at level 1e308 (|x| ~ 1e154 on the level set) and 1e200
    (|x| ~ 1e100, x1^2 x2 ~ 1e300 times P's entries and x) it overflows; at 1e150 it does not."""
    from roa.search import _sos_program as sos_program

    def never(*a, **k):
        raise AssertionError("an SOS program was built")

    monkeypatch.setattr(sos_program.FixedLevel, "__init__", never)
    for level in ("1e308", "1e200"):  # the command line refuses them when parsing --level
        try:
            code = main(["certify", "--system", "vanderpol", "--level", level])
        except SystemExit as exc:
            code = exc.code
        err = capsys.readouterr().err.strip()
        assert code == 2 and "--level" in err and "outside (0, 1e+150]" in err, err
        assert "Traceback" not in err
    with pytest.raises(RoaInputError, match="^level 1e\\+308 overflows"):
        roa.certify(vanderpol(), level=1e308)
    with pytest.raises(RoaInputError, match="check_above x level"):
        roa.certify(vanderpol(), level=2.3, check_above=1e307)
    assert roa.certify(vanderpol(), level=1e150, validator="interval").status is (
        roa.Verdict.REFUTED
    )
