"""Bounded work (reliability issue, item 3): a field that is NaN at the start ends the run instead
of looping forever, and a polynomial V too large to evaluate is refused before any work.

Each run happens in a subprocess with a time limit: on a hang the test fails (it does not hang).
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

import roa
from roa.errors import RoaInputError

NAN_FIELD = textwrap.dedent(
    """
    import dataclasses, json
    import roa
    from roa.systems.vanderpol import vanderpol

    def field(t, x, xp):  # sqrt of a negative number: NaN wherever x1 < -2
        return (-x[1] + 0.0 * xp.sqrt(x[0] + 2.0), x[0] + (x[0] ** 2 - 1) * x[1])

    s = dataclasses.replace(vanderpol(), field=field, params=None, name="nan-field")
    run = roa.simulate(s, [-3.0, 0.5])
    grid = roa.grid_slice(s, ("x1", "x2"), [(-3.0, -2.5), (-1.0, 1.0)], (3, 3))
    res = roa.basin(s, grid, run=roa.RunOptions(n_jobs=1))
    print(json.dumps({"status": run.status.value, "message": run.message,
                      "counts": res.counts, "failures": res.step_size_failures}))
    """
)


def test_a_field_nan_at_the_start_ends_the_run():
    out = subprocess.run([sys.executable, "-c", NAN_FIELD], capture_output=True, text=True,
                         timeout=120)  # fmt: skip
    assert out.returncode == 0, out.stderr[-2000:]
    import json

    data = json.loads(out.stdout.strip().splitlines()[-1])
    assert data["status"] == "undecided" and "not finite" in data["message"]
    assert data["counts"]["undecided"] == 9 and data["failures"] == 9


@pytest.mark.parametrize(
    "monomials, match",
    [([[2**62, 0]], "at most 40"), ([[10**6, 0]], "at most 40"), ([[1e20, 0]], "at most 40")],
)
def test_huge_exponents_are_refused_before_work(monomials, match):
    with pytest.raises(RoaInputError, match=match):
        roa.PolynomialLyapunov(monomials, [1.0], [0.0, 0.0])


def test_too_many_terms_are_refused():
    with pytest.raises(RoaInputError, match="at most 100000 terms"):
        roa.PolynomialLyapunov([[2, 0]] * 100_001, [1.0] * 100_001, [0.0, 0.0])


def test_a_high_odd_interval_power_is_an_enclosure_in_few_steps():
    import numpy as np

    from roa.proof._interval import Interval

    x = Interval(np.array([-1.5, 0.5, -0.9]), np.array([-1.0, 1.1, 1.01]))
    k = 1001
    y = x**k
    for a, lo, hi in zip((-1.25, 0.8, 1.0), y.lo, y.hi, strict=True):
        assert lo <= a**k <= hi or (np.isinf(lo) and lo < 0) or np.isinf(hi)
    assert np.all(y.lo <= y.hi)


def test_an_sos_program_too_large_is_refused_before_it_is_built():
    """Reliability issue item 4: a 50-state system made Clarabel request terabytes and abort. The
    Gram basis of a quadratic V's program holds every monomial of degree <= 2: C(n + 2, 2) = 496
    for n = 30, above the 400 built here, so the program is refused with a message (at once).
    V couples every pair of states (P = I + 0.01 11'), so the sparse route, which takes only a
    separable V, does not apply either."""
    import time

    import numpy as np

    from roa.lyapunov import QuadraticLyapunov
    from roa.search._sdp import MAX_GRAM_BLOCK

    n = 30

    def field(t, x, xp):
        return tuple(-x[i] + 0.1 * x[(i + 1) % n] * x[(i + 2) % n] for i in range(n))

    system = roa.System("ring30", field, (0.0,) * n, tuple(f"x{i}" for i in range(n)))
    t0 = time.perf_counter()
    V = QuadraticLyapunov(np.eye(n) + 0.01 * np.ones((n, n)), np.zeros(n))
    cert = roa.certify(system, V, level=roa.SosLevel())
    assert cert.status is roa.Verdict.INCONCLUSIVE and cert.level is None
    assert cert.sos is not None and cert.sos.status is roa.SosStatus.TOO_LARGE
    assert cert.sos.sizes["gram_block"] == 496 > MAX_GRAM_BLOCK
    assert "not built" in cert.message and time.perf_counter() - t0 < 30


def test_a_slow_field_ends_at_the_time_limit(tmp_path, capsys):
    """A field that sleeps held roa simulate forever; with --time-limit the run ends undecided,
    naming the reason, within about the budget."""
    import time

    from roa.cli import main

    src = tmp_path / "slow.py"
    src.write_text(
        "import time\nfrom roa import System\n"
        "def field(t, x, xp):\n"
        "    if getattr(xp, 'name', '') == 'numpy':\n        time.sleep(0.02)\n"
        "    return (-x[1], x[0] + (x[0] ** 2 - 1) * x[1])\n"
        "SYSTEM = System(name='slow', field=field, equilibrium=(0.0, 0.0), state_names=('x1', 'x2'))\n"
    )
    t0 = time.perf_counter()
    assert main(["simulate", "--system", f"{src}:SYSTEM", "--x0", "0.5,0.5", "--time-limit", "0.5",
                 "--json"]) == 0  # fmt: skip
    assert time.perf_counter() - t0 < 10
    import json

    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "undecided" and "wall-clock budget" in out["message"]
    assert main(["simulate", "--system", "vanderpol", "--x0", "0.5,0.5", "--time-limit", "-1"]) == 2
    assert "time_limit" in capsys.readouterr().err


def _ring(n: int) -> roa.System:
    def field(t, x, xp):
        return tuple(-x[i] + 0.1 * x[(i + 1) % n] * x[(i + 2) % n] for i in range(n))

    return roa.System(f"ring{n}", field, (0.0,) * n, tuple(f"x{i}" for i in range(n)))


def test_a_polynomial_v_search_too_large_is_refused_before_any_work():
    """Deliver 3 (SDP sizes estimated before building): a degree-4 V in 30 states has 41385
    coefficients at least; its programs would not fit in memory. The V-s search used to spend
    hours expanding them; it now ends inconclusive with the reason, before the seed's search."""
    cert = roa.certify(_ring(30), roa.VsIteration(4))
    assert cert.status is roa.Verdict.INCONCLUSIVE
    assert "41385 coefficients" in cert.message and "not built" in cert.message


def test_a_gram_block_too_large_is_refused_where_it_is_built():
    from roa.search._sdp import MAX_GRAM_BLOCK, Program, ProgramTooLarge, monomials

    basis = monomials(12, 3, 0)
    assert len(basis) > MAX_GRAM_BLOCK
    with pytest.raises(ProgramTooLarge, match=f"{len(basis)} monomials"):
        Program(12).gram(basis, None)


def test_a_validation_out_of_time_is_inconclusive_saying_so():
    """A wall-clock budget ends the branch and bound between batches: inconclusive, never
    certified (the budget is spent before the first split here)."""
    import roa
    from roa.systems.vanderpol import vanderpol

    itv = roa.IntervalOptions(time_limit=1e-9, batch=1)
    cert = roa.certify(vanderpol(), level=2.3, interval=itv, validator="interval")
    assert cert.status is roa.Verdict.INCONCLUSIVE and "time limit" in cert.message
    # the default (auto) validator backs the branch and bound up with the exact SOS certificate
    auto = roa.certify(vanderpol(), level=2.3, interval=itv)
    assert auto.status is roa.Verdict.CERTIFIED and auto.validation.meta["method"] != "interval"
    assert roa.certify(vanderpol(), level=2.3).status is roa.Verdict.CERTIFIED
    with pytest.raises(roa.RoaInputError, match="time_limit must be a number of seconds"):
        roa.IntervalOptions(time_limit=-1)
