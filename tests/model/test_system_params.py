"""Systems with parameters: ``field(t, x, xp, p)``, ``with_params``, and the typed extension fields.

Van der Pol declares ``mu``: its field with ``p.mu`` must equal the closed form
``(-x2, x1 + mu (x1^2 - 1) x2)`` for every ``mu``, and a certificate follows the parameter value
(level 2.30 of the benchmark P is certified at mu = 1, refuted at mu = 2: the published optimum
2.3045 is for mu = 1).
"""

from __future__ import annotations

import dataclasses
import pickle

import numpy as np
import pytest

import roa
from roa.errors import RoaInputError
from roa.model._fingerprint import system_fingerprint
from roa.systems.vanderpol import vanderpol


def test_field_with_parameters_matches_the_closed_form():
    X = np.random.default_rng(0).uniform(-2, 2, (50, 2))
    for mu in (0.5, 1.0, 3.0):
        system = vanderpol().with_params(mu=mu)
        expected = np.stack([-X[:, 1], X[:, 0] + mu * (X[:, 0] ** 2 - 1) * X[:, 1]], axis=1)
        np.testing.assert_array_equal(system.f(X), expected)
        assert system.params.mu == system.params["mu"] == mu


def test_a_certificate_follows_the_parameter_value():
    base = vanderpol()
    assert roa.certify(base, level=2.30).certified
    stiff = base.with_params(mu=2.0)
    assert roa.certify(stiff, roa.default_lyapunov(base), level=2.30).status is roa.Verdict.REFUTED
    assert system_fingerprint(stiff) != system_fingerprint(base)
    assert system_fingerprint(stiff.with_params(mu=1.0)) == system_fingerprint(base)


def test_bad_parameters_are_input_errors_naming_them():
    system = vanderpol()
    with pytest.raises(RoaInputError, match="no parameter 'nu'.*declared: mu"):
        system.with_params(nu=1.0)
    with pytest.raises(RoaInputError, match=r"params\['mu'\] must be a number"):
        system.with_params(mu="fast")
    with pytest.raises(RoaInputError, match=r"params\['mu'\] must be finite"):
        system.with_params(mu=float("nan"))
    plain = roa.System("lin", lambda t, x, xp: (-x[0],), (0.0,), ("x",))
    with pytest.raises(RoaInputError, match="declares no parameters"):
        plain.with_params(a=1.0)
    with pytest.raises(AttributeError, match="read-only"):
        system.params.mu = 2.0  # type: ignore[misc]


def test_parameterised_systems_pickle_and_hash():
    system = vanderpol(mu=1.5)
    again = pickle.loads(pickle.dumps(system))
    X = np.array([[0.3, -0.2], [1.0, 2.0]])
    np.testing.assert_array_equal(again.f(X), system.f(X))
    assert hash(again.params) == hash(system.params) and again.params == system.params
    assert dataclasses.replace(system).params == system.params  # replace keeps the binding


def test_typed_extension_fields_take_older_meta_entries():
    def kernels():
        raise AssertionError("not called")

    old = roa.System("k", lambda t, x, xp: (-x[0],), (0.0,), ("x",),
                     meta={"numba": kernels, "note": "kept"})  # fmt: skip
    assert old.numba is kernels and old.numba_fast is None and old.meta == {"note": "kept"}
    assert dataclasses.replace(old, numba=None).numba is None
