"""Sign symmetry of the SOS programs (:mod:`roa.search._sos_program`).

The symmetries are checked against a brute-force enumeration of every 0/1 vector; the split
program against the unsplit one: averaging a certificate over the group keeps ``Q >= t I`` (the
group acts by diagonal +-1 matrices), so the largest margin ``t`` is the same with the Gram
matrices block-diagonal by parity class (up to the solver's tolerance), and the split
certificate passes the same exact check.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import roa
from roa.proof._putinar import check_level
from roa.proof._sos_check import exact_data
from roa.search._sdp import monomials
from roa.search._sos_program import FixedLevel, dense, propose, sign_symmetries, split
from roa.systems.vanderpol import P_BENCHMARK, vanderpol


def _brute(polys, nv):
    """Every 0/1 vector ``s`` with ``s . m`` even for every monomial (the group itself)."""
    return {s for s in itertools.product((0, 1), repeat=nv)
            if all(sum(a * b for a, b in zip(s, m, strict=True)) % 2 == 0
                   for p in polys for m in p)}  # fmt: skip


def _span(basis, nv):
    out = {tuple([0] * nv)}
    for s in basis:
        out |= {tuple((a + b) % 2 for a, b in zip(s, t, strict=True)) for t in out}
    return out


@pytest.mark.parametrize("seed", range(20))
def test_the_symmetries_span_exactly_the_brute_force_group(seed):
    rng = np.random.default_rng(seed)
    nv = int(rng.integers(1, 6))
    polys = [{tuple(int(e) for e in rng.integers(0, 4, nv)): 1.0
              for _ in range(int(rng.integers(1, 5)))} for _ in range(2)]  # fmt: skip
    basis = sign_symmetries(polys, nv)
    assert _span(basis, nv) == _brute(polys, nv)
    assert len(_span(basis, nv)) == 2 ** len(basis)  # a basis: independent vectors


def test_split_keeps_every_monomial_once_and_separates_the_classes():
    syms = sign_symmetries([{(2, 0, 0): 1, (1, 1, 1): 1}], 3)  # poly3d: flip two of three
    assert len(syms) == 2
    basis = monomials(3, 2, 1)
    parts = split(basis, syms)
    assert sorted(m for p in parts for m in p) == sorted(basis)
    for p in parts:
        keys = {tuple(sum(a * b for a, b in zip(s, m, strict=True)) % 2 for s in syms) for m in p}
        assert len(keys) == 1
    assert split(basis, []) == [basis]


def test_the_split_program_has_the_unsplit_optimum_and_passes_the_exact_check():
    """Van der Pol (odd field: the global flip) at level 2.0: the margin ``t`` of the program with
    Gram matrices split by parity equals the unsplit program's, and the split certificate is
    proved exactly."""
    system = vanderpol()
    V = roa.QuadraticLyapunov(P_BENCHMARK, np.zeros(2))
    data = exact_data(system, V)
    cand = propose(data, 2.0)
    assert cand.sizes["sign_symmetries"] == 1 and len(cand.certificate.blocks(0)) == 2
    whole = FixedLevel(data, dense(data, symmetry=False), eps=cand.eps).solve(2.0)
    assert len(whole.certificate.blocks(0)) == 1
    assert whole.margin is not None and cand.margin is not None
    assert cand.margin == pytest.approx(whole.margin, rel=1e-4)
    assert check_level(data, 2.0, cand.eps, cand.certificate).ok
    assert check_level(data, 2.0, cand.eps, whole.certificate).ok


@pytest.mark.parametrize("path, level", [("examples/systems/pendulum.py:SYSTEM", 9.0),
                                         ("examples/systems/quadrotor2d.py:SYSTEM", 0.12)])  # fmt: skip
def test_the_split_recast_program_has_the_unsplit_optimum(path, level):
    """Recast fields (sin/cos): the program split by the flips that fix every polynomial of the
    identity (its Gram blocks by parity class, its equality multipliers over the invariant
    monomials only) has the unsplit program's margin, and both certificates pass the exact
    check."""
    from pathlib import Path

    from roa.proof._recast import level_scale, recast_preconditions
    from roa.search._sos_program import default_eps

    root = Path(__file__).resolve().parents[2]
    system = roa.load_system(f"{root / path}")
    V = roa.default_lyapunov(system)
    data, why = recast_preconditions(system, V, level, None, level_scale(V, level))
    assert data is not None, why
    eps = default_eps(data)
    cand = propose(data, level, eps=eps)
    assert cand.sizes["sign_symmetries"] >= 1 and cand.certificate is not None
    whole = FixedLevel(data, dense(data, symmetry=False), eps=eps).solve(level)
    assert whole.certificate is not None
    assert len(whole.certificate.grams) < len(cand.certificate.grams)
    assert sum(len(b) for b, _ in whole.certificate.free) > sum(
        len(b) for b, _ in cand.certificate.free)  # fmt: skip
    assert cand.margin == pytest.approx(whole.margin, abs=1e-5 * max(1.0, abs(whole.margin)))
    assert check_level(data, level, eps, cand.certificate).ok
    assert check_level(data, level, eps, whole.certificate).ok
