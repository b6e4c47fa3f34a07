"""Malformed stored SOS certificates of every pattern: refused with a reason, in bounded time.

A genuine certificate of each stored pattern (dense, independent blocks, sparse sum, recast
Putinar, parameter box, domain) is re-checked; then Hypothesis replaces one value anywhere in it
(or its ``eps``/``level``) by a malformed one (exponents, underscores, spaces, non-ASCII digits,
decimals, huge integers, wrong types and shapes). The re-check must never raise anything but
:class:`roa.RoaInputError` (a one-line message), never certify a proof-carrying field it cannot
parse, and end within seconds.
"""

from __future__ import annotations

import json
import time
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st
from sos_systems import poly3d_block as _poly3d, ring as _ring

import roa
import roa.io
from roa.certification._result import Certificate
from roa.errors import RoaInputError
from roa.proof._sos_check import parse_rational
from roa.status import Verdict
from roa.systems.vanderpol import P_BENCHMARK, vanderpol


def _strip():
    return roa.System("vdp-strip", lambda t, x, xp: (-x[1], x[0] - x[1] + x[0] ** 2 * x[1]),
                      (0.0, 0.0), ("x1", "x2"), margin=lambda x, xp: 0.25 - x[0] * x[0],
                      domain_description="|x1| < 0.5")  # fmt: skip


def _pendulum():
    return roa.System("pendulum", lambda t, x, xp: (x[1], -xp.sin(x[0]) - x[1]), (0.0, 0.0),
                      ("theta", "omega"))  # fmt: skip


PATTERNS = {  # name -> (system, V, level, validator); each stores a different certificate form
    "dense": (vanderpol(), P_BENCHMARK, 2.0, roa.SosValidator()),
    "blocks": (
        roa.System(
            "poly3d-x2",
            lambda t, x, xp: _poly3d(x, 0) + _poly3d(x, 3),
            (0.0,) * 6,
            tuple(f"x{i}" for i in range(6)),
        ),
        np.eye(6),
        2.9,
        roa.SosValidator(),
    ),  # fmt: skip
    "sum": (_ring(5), np.eye(5), 0.8, roa.SosValidator(route="sparse")),
    "putinar": (_pendulum(), None, 1.0, roa.SosValidator(fallback=False)),
    "box": (
        vanderpol().with_ranges(mu=(0.9, 1.1)),
        P_BENCHMARK,
        1.0,
        roa.SosValidator(fallback=False),
    ),  # fmt: skip
    "domain": (_strip(), P_BENCHMARK, 0.3, roa.SosValidator()),
}
#: Fields that carry no proof (reports and identifiers): a re-check may ignore their content.
INFORMATIONAL = {"cliques", "digest", "method", "residual", "min_pivot", "k", "recast"}


@pytest.fixture(scope="module")
def genuine() -> dict[str, tuple[Any, dict[str, Any]]]:
    out = {}
    for name, (system, P, level, validator) in PATTERNS.items():
        cert = roa.certify(system, P, level=level, validator=validator)
        assert cert.certified and cert.method == "sos-exact", (name, cert.message)
        data = json.loads(roa.io.to_json(cert.to_dict()))
        assert Certificate.from_dict(data, system).reverify().certified, name
        out[name] = (system, data)
    return out


def _paths(node: Any, prefix: tuple = ()) -> list[tuple]:
    out = [prefix]
    if isinstance(node, dict):
        for k, v in node.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node[:6]):  # the first entries of each list suffice
            out += _paths(v, (*prefix, i))
    return out


def _replace(data: Any, path: tuple, value: Any) -> Any:
    out = json.loads(json.dumps(data))
    node = out
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return out


BAD = st.one_of(
    st.sampled_from(
        [
            "1e100000",
            "-1e100000",
            "1E5",
            "1_000",
            "١٢",
            "１",
            " 1",
            "1 ",
            "1.5",
            "nan",
            "inf",
            "",
            "1/0",
            "+1",
            "--1",
            "1//2",
            "0x10",
            "9" * 2001,
            "1/" + "7" * 2000,
        ]
    ),  # fmt: skip
    st.sampled_from(
        [
            None,
            True,
            1.5,
            float("nan"),
            10**3000,
            -(10**3000),
            [],
            {},
            ["1"],
            [["1", "2"]],
            {"a": 1},
            [[[]]],
        ]
    ),  # fmt: skip
    st.text(max_size=12).filter(lambda s: not _is_rational(s)),
    st.lists(st.text(max_size=4), max_size=3),
)


def _is_rational(s: str) -> bool:
    try:
        parse_rational(s, "x")
        return True
    except ValueError:
        return False


@pytest.mark.parametrize("pattern", sorted(PATTERNS))
@settings(max_examples=25, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])  # fmt: skip
@given(data=st.data(), bad=BAD)
def test_malformed_certificates_are_refused_in_bounded_time(genuine, pattern, data, bad):
    system, cert = genuine[pattern]
    paths = [("certificate", *p) for p in _paths(cert["certificate"])] + [("eps",), ("level",)]
    path = data.draw(st.sampled_from(paths[1:] if paths[0] == ("certificate",) else paths))
    forged = _replace(cert, path, bad)
    t0 = time.perf_counter()
    try:
        r = Certificate.from_dict(forged, system).reverify()
    except RoaInputError as exc:
        assert "\n" not in str(exc)
        return
    finally:
        assert time.perf_counter() - t0 < 30, f"{pattern}: {path} = {str(bad)[:40]}"
    if r.status is Verdict.CERTIFIED:
        assert set(path) & INFORMATIONAL, (pattern, path, str(bad)[:40], r.message)


@pytest.mark.parametrize("text", ["0", "-3/4", "12345678901234567890/3", "7"])
def test_the_rational_grammar_accepts_what_roa_writes(text):
    from fractions import Fraction

    assert parse_rational(text, "x") == Fraction(text)


@pytest.mark.parametrize("text", ["1e5", "1_000", "١٢", " 1", "1.5", "+1", "1/0", "", "1/-2"])
def test_the_rational_grammar_refuses_everything_else(text):
    with pytest.raises(ValueError):
        parse_rational(text, "x")
