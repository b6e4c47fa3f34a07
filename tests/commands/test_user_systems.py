"""Users' own systems of eight kinds, each against an independently computed reference.

Kinds (``examples/systems/*.py`` and ``examples/vanderpol_system.py``): one state, a shifted
equilibrium, polynomial 2-D and 3-D, trigonometric with a second stable equilibrium, rational,
degenerate linearisation, and the Van der Pol benchmark. The largest V-level is a closed form where
one exists (stated in each example's docstring) and otherwise a scipy multistart
(SLSQP: min V(x) s.t. V'(x) = 0, |x - x_eq| >= 1e-2, 60 starts; agreement 1e-4 relative). For each:
``roa.level_search`` matches the reference, ``roa.certify`` certifies 0.999 x it and refutes
1.001 x it (where interval validation applies), and basin statuses of chosen points are right.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy import linalg, optimize

import roa

EX = Path(__file__).resolve().parents[2] / "examples"


def _load(name: str) -> roa.System:
    path = EX / "vanderpol_system.py" if name == "vanderpol" else EX / "systems" / f"{name}.py"
    return roa.load_system(f"{path}:SYSTEM")


def _multistart(system: roa.System, P: np.ndarray, box: float, seed: int = 0) -> float:
    """Independent reference: min (x-c)'P(x-c) s.t. V'(x) = 0, away from the equilibrium.

    V' is differenced by forward steps as scipy's default (step ``sqrt(eps) max(1, |x_i|)``
    signed by ``x_i``), with the ``n + 1`` points evaluated in one call of the field."""
    c = system.x_eq
    n = system.n

    def vdots(X: np.ndarray) -> np.ndarray:
        return 2.0 * np.einsum("...i,ij,...j->...", X - c, P, system.f(X))

    def vdot(x: np.ndarray) -> float:
        return float(vdots(x))

    def vdot_jac(x: np.ndarray) -> np.ndarray:
        h = np.sqrt(np.finfo(float).eps) * np.where(x >= 0, 1.0, -1.0) * np.maximum(1.0, abs(x))
        steps = (x + h) - x
        X = np.vstack([x, x + np.diag(steps)])
        v = vdots(X)
        return (v[1:] - v[0]) / steps

    rng = np.random.default_rng(seed)
    best = np.inf
    for _ in range(60):
        x0 = c + rng.uniform(-box, box, n)
        res = optimize.minimize(
            lambda x: float((x - c) @ P @ (x - c)),
            x0,
            jac=lambda x: 2.0 * P @ (x - c),
            method="SLSQP",
            constraints=[
                {"type": "eq", "fun": vdot, "jac": vdot_jac},
                {"type": "ineq", "fun": lambda x: float((x - c) @ (x - c)) - 1e-4,
                 "jac": lambda x: 2.0 * (x - c)},
            ],
            options={"ftol": 1e-14, "maxiter": 500},
        )  # fmt: skip
        if res.success and abs(vdot(res.x)) < 1e-9:
            best = min(best, float(res.fun))
    return best


def _pendulum_P() -> np.ndarray:
    A = np.array([[0.0, 1.0], [-1.0, -1.0]])  # Jacobian of the damped pendulum at the origin
    return linalg.solve_continuous_lyapunov(A.T, -np.eye(2))


#: name -> (reference level, how it was obtained)
CLOSED_FORM = {"one_state": 1.0, "shifted": 1.0, "poly3d": 3.0, "degenerate": 1.0,
               "rational": 1.0}  # fmt: skip
# rational (V = |x|^2): V' = 2 x1^2 (x1 / (1 + x2^2) - 1) - 2 x2^2 < 0 on 0 < |x|^2 < 1 (x1 <= 0:
# both terms <= 0, not both 0; 0 < x1 < 1: x1 / (1 + x2^2) < 1), and V'(1, 0) = 0. The multistart
# finds it from 1 start in 60 (the others stop on a positive directional derivative).


def _reference(name: str, system: roa.System, P: np.ndarray) -> float:
    if name in CLOSED_FORM:
        return CLOSED_FORM[name]
    return _multistart(system, P, box=3.0)


NAMES = ["one_state", "shifted", "poly2d", "poly3d", "pendulum", "rational", "degenerate",
         "vanderpol"]  # fmt: skip


@pytest.fixture(scope="module", params=NAMES)
def case(request):
    name = request.param
    system = _load(name)
    P = _pendulum_P() if name == "pendulum" else np.asarray(system.lyapunov, dtype=float)
    return name, system, P, _reference(name, system, P)


def test_default_lyapunov_is_the_files_or_the_lyapunov_equation(case):
    name, system, P, _ = case
    assert np.allclose(roa.default_lyapunov(system).P, P, rtol=1e-10, atol=1e-12)


def test_level_search_matches_the_reference(case):
    name, system, P, ref = case
    res = roa.level_search(system, shape="level")
    assert res.status in (roa.LevelStatus.AGREE, roa.LevelStatus.FOUND), res.message
    assert res.level == pytest.approx(ref, rel=1e-4)


def test_certify_below_and_refute_above(case):
    name, system, P, ref = case
    below = roa.certify(system, level=0.999 * ref)
    above = roa.certify(system, level=1.001 * ref)
    assert below.status is roa.Verdict.CERTIFIED, below.message
    assert above.status is roa.Verdict.REFUTED, above.message
    assert above.validation is not None and above.validation.witness_check["confirmed"]


def test_wrong_equilibrium_is_a_clear_error():
    bad = roa.System("bad", lambda t, x, xp: (-x[0] + 1.0,), (0.0,), ("x",))
    for call in (roa.level_search, roa.certify):
        with pytest.raises(roa.RoaInputError, match=r"is not an equilibrium: f\(x_eq\) = \[1\.\]"):
            call(bad)


def test_unstable_linearisation_is_a_clear_error():
    saddle = roa.System("saddle", lambda t, x, xp: (x[0], -x[1]), (0.0, 0.0), ("a", "b"))
    with pytest.raises(roa.RoaInputError, match="linearisation .* is unstable"):
        roa.certify(saddle, np.eye(2))


def test_field_with_wrong_size_is_a_clear_error():
    three = roa.System("three", lambda t, x, xp: (x[0], x[1], -x[0]), (0.0, 0.0), ("a", "b"))
    with pytest.raises(roa.SystemDefinitionError, match="returns 3 components, expected 2"):
        roa.simulate(three, [0.1, 0.1])


def test_pendulum_settles_at_another_equilibrium():
    """From theta' = 7 rad/s the damped pendulum swings over once and settles at theta = 2 pi."""
    system = _load("pendulum")
    run = roa.simulate(system, [0.0, 7.0], rules=roa.StopRules(t_final=80))
    assert run.status is roa.RunStatus.CONVERGED_ELSEWHERE, run.message
    assert run.meta["equilibrium_reached"] == pytest.approx([2 * np.pi, 0.0], abs=1e-8)
    grid = roa.grid_slice(system, ("theta", "omega"), [(-1.0, 1.0), (-7.0, 7.0)], (3, 3))
    res = roa.basin(system, grid, rules=roa.StopRules(t_final=80), run=roa.RunOptions(n_jobs=1))
    assert res.counts["converged_elsewhere"] >= 2 and res.counts["undecided"] == 0
    assert sum(res.counts.values()) == res.n


@pytest.mark.parametrize(
    ("name", "x0", "status"),
    [
        ("one_state", [0.9], roa.RunStatus.CONVERGED),
        ("one_state", [1.1], roa.RunStatus.DIVERGED),
        ("shifted", [2.9], roa.RunStatus.CONVERGED),
        ("shifted", [0.9], roa.RunStatus.DIVERGED),
        ("poly2d", [2.0, 0.4], roa.RunStatus.CONVERGED),  # x1 x2 = 0.8 < 1
        ("poly2d", [2.0, 0.6], roa.RunStatus.DIVERGED),  # x1 x2 = 1.2 > 1
        ("poly3d", [0.5, 0.5, 0.5], roa.RunStatus.CONVERGED),
        ("rational", [0.9, 0.0], roa.RunStatus.CONVERGED),
        ("degenerate", [0.5, 0.5], roa.RunStatus.UNDECIDED),  # x' = -x^3 converges like t^(-1/2)
    ],
)
def test_basin_statuses(name, x0, status):
    system = _load(name)
    run = roa.simulate(system, x0, rules=roa.StopRules(t_final=60))
    assert run.status is status, run.message
    box = roa.box_sample(system, [(v, v + 1e-12) for v in x0], 3, seed=0)
    res = roa.basin(system, box, rules=roa.StopRules(t_final=60), run=roa.RunOptions(n_jobs=1))
    assert res.counts[status.value] == 3, res.counts  # the batch integrator agrees
    if status is roa.RunStatus.UNDECIDED:
        assert "still moving" in run.message


def test_a_file_whose_field_has_the_wrong_size_is_one_line_at_load(tmp_path, capsys):
    """Issue 11: the CLI names the file and the problem, no traceback."""
    from roa.cli import main

    f = tmp_path / "wrong.py"
    f.write_text(
        "from roa import System\n"
        "SYS = System(name='s', field=lambda t, x, xp: (-x[0], x[1]), equilibrium=(0.0,),\n"
        "             state_names=('x',))\n"
    )
    assert main(["khalil", "--system", f"{f}:SYS"]) == 2
    err = capsys.readouterr().err
    assert "wrong.py:SYS" in err and "must return 1 numbers" in err and "Traceback" not in err
