"""Policies as objects and V's capabilities as methods (issue #35 items 2 and 3).

* No module outside ``roa/lyapunov`` tests V's representation (``.P is None``, ``.terms``,
  ``.gram``, ``as_quadratic``, ``getattr(V, "terms")``), and none branches on message text: an AST
  scan of ``roa`` and ``ipc_paper``, itself checked on snippets that must be flagged.
* Validators, proposers and sources declare what they can do; the pipeline's back-off reads
  ``Validation.reason``, never the message.
* The proof/search boundary: the 50-digit check of a proposed witness refuses a tampered point.
"""

from __future__ import annotations

import ast
import pathlib
from types import SimpleNamespace

import numpy as np
import pytest

import roa
from roa.certification._pipeline import Attempt, RetryPolicy, Run, WitnessRefuter
from roa.certification._strategies import (
    AutoValidator,
    CandidateLevel,
    Declared,
    GivenLevel,
    IntervalValidator,
    SampledLevel,
    SosLevel,
    SosValidator,
    VSource,
    WorstCase,
    as_validator,
)
from roa.lyapunov import FunctionLyapunov, PolynomialLyapunov, QuadraticLyapunov
from roa.options import BNB_DIM
from roa.proof._validation import Reason, Validation
from roa.search._rays import ray_box
from roa.status import Verdict
from roa.systems.vanderpol import vanderpol

ROOT = pathlib.Path(__file__).resolve().parents[2]
#: Attributes of V's representation that only roa/lyapunov reads.
REPRESENTATION = {"terms", "gram", "as_quadratic"}
#: Capabilities that are declared fields, never looked up with a default.
DECLARED = {"P", "terms", "gram", "whitened", "refutes", "max_bnb_dim", "backoff"}


#: Keys of a record whose value is a description for people (read its declared flags instead).
DESCRIPTIONS = {"cover", "message"}


def _reads_key(node: ast.AST, keys: set[str]) -> bool:
    """Whether ``node`` reads ``d[key]`` or ``d.get(key...)`` for a key in ``keys``."""
    for m in ast.walk(node):
        if isinstance(m, ast.Subscript) and isinstance(m.slice, ast.Constant):
            if m.slice.value in keys:
                return True
        if (isinstance(m, ast.Call) and isinstance(m.func, ast.Attribute)
                and m.func.attr == "get" and m.args and isinstance(m.args[0], ast.Constant)
                and m.args[0].value in keys):  # fmt: skip
            return True
    return False


def violations(source: str) -> list[tuple[int, str]]:
    """Representation tests of V and branches on message text in ``source`` (an object reading
    its own fields, ``self.x``, is not one; a call ``poly.terms()`` is sympy's, not V's)."""
    tree = ast.parse(source)
    called = {id(n.func) for n in ast.walk(tree) if isinstance(n, ast.Call)}
    out: list[tuple[int, str]] = []

    def own(node: ast.expr) -> bool:
        return isinstance(node, ast.Name) and node.id == "self"

    for n in ast.walk(tree):
        if isinstance(n, ast.Compare):
            left = n.left
            nones = [isinstance(c, ast.Constant) and c.value is None for c in n.comparators]
            if isinstance(left, ast.Attribute) and left.attr == "P" and any(nones):
                if not own(left.value):
                    out.append((n.lineno, ".P is None"))
            sides = [n.left, *n.comparators]
            if any(isinstance(s, ast.Attribute) and s.attr == "message" for s in sides) and any(
                isinstance(o, ast.In | ast.NotIn | ast.Eq | ast.NotEq) for o in n.ops
            ):
                out.append((n.lineno, "message text"))
            if any(isinstance(o, ast.In | ast.NotIn) for o in n.ops) and any(
                _reads_key(c, DESCRIPTIONS) for c in n.comparators
            ):
                out.append((n.lineno, "description text"))
        if isinstance(n, ast.Attribute) and isinstance(n.ctx, ast.Load):
            if n.attr == "as_quadratic":
                out.append((n.lineno, "as_quadratic"))
            elif n.attr in REPRESENTATION and id(n) not in called and not own(n.value):
                out.append((n.lineno, f".{n.attr}"))
        if isinstance(n, ast.Call) and isinstance(n.func, ast.Attribute):
            base = n.func.value
            if n.func.attr in ("startswith", "endswith", "find", "index") and (
                isinstance(base, ast.Attribute) and base.attr == "message"
            ):
                out.append((n.lineno, "message text"))
        if isinstance(n, ast.Call) and isinstance(n.func, ast.Name):
            if n.func.id in ("getattr", "hasattr") and len(n.args) >= 2:
                name = n.args[1]
                if isinstance(name, ast.Constant) and name.value in DECLARED:
                    out.append((n.lineno, f"getattr {name.value!r}"))
    return out


@pytest.mark.parametrize(
    "snippet",
    [
        "if V.P is None: pass",
        "x = V.P is not None",
        "for a in V.terms: pass",
        "t = lyap.terms.items()",
        "q = V.as_quadratic()",
        "g = getattr(V, 'gram', None)",
        "r = getattr(validator, 'refutes', True)",
        "if 'box cover' in v.message: pass",
        "if v.message == 'x': pass",
        "if res.message.startswith('no'): pass",
        "c = 'component' in str(info.get('cover', ''))",
        "c = 'component' in info['cover']",
    ],
)
def test_the_scan_flags_each_kind_of_violation(snippet):
    assert violations(snippet), snippet


@pytest.mark.parametrize(
    "snippet",
    [
        "q = V.quadratic_view()",
        "t = V.polynomial_view()",
        "if self.P is None: pass",
        "t = poly.terms()",
        "m = v.message",
        "if v.reason is Reason.NO_COVER: pass",
    ],
)
def test_the_scan_passes_capability_methods_and_own_fields(snippet):
    assert not violations(snippet), snippet


def test_no_module_outside_lyapunov_tests_v_representation_or_message_text():
    found = []
    for folder in ("roa", "ipc_paper"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            rel = path.relative_to(ROOT)
            if rel.parts[:2] == ("roa", "lyapunov") or "tests" in rel.parts:
                continue  # the candidates themselves, and tests (which read what they check)
            found += [f"{rel}:{line}: {what}" for line, what in violations(path.read_text())]
    assert not found, "\n".join(found)


# -- V's capabilities ---------------------------------------------------------------------------------
def test_capabilities_of_each_kind_of_v():
    P = np.array([[2.0, 0.5], [0.5, 1.0]])
    quad = QuadraticLyapunov(P, [0.0, 0.0])
    assert quad.quadratic_view() is quad and quad.is_quadratic and quad.is_polynomial
    assert np.array_equal(quad.quadratic_matrix(), P)
    assert np.array_equal(quad.ellipsoid_matrix(), P)
    assert quad.polynomial_view() == {(2, 0): 2.0, (1, 1): 1.0, (0, 2): 1.0}
    assert quad.gram_view() is not None and quad.has_exact_description()
    off = QuadraticLyapunov(P, [1.0, 0.0])
    assert off.quadratic_matrix() is not None and off.ellipsoid_matrix() is None
    # a degree-2 polynomial is no QuadraticLyapunov: no quadratic view, its terms only
    poly = PolynomialLyapunov([[2, 0], [0, 2]], [1.0, 1.0], [0.0, 0.0])
    assert poly.quadratic_view() is None and not poly.is_quadratic and poly.is_polynomial
    assert poly.gram_view() is None and poly.unwhitened() is None
    func = FunctionLyapunov(lambda x, xp: xp.log(1 + x[0] ** 2 + x[1] ** 2), [0.0, 0.0])
    assert func.quadratic_view() is None and func.polynomial_view() is None
    assert not func.has_exact_description()
    with pytest.raises(roa.RoaInputError, match="not polynomial"):
        func.with_gram(([(1, 0), (0, 1)], np.eye(2)))


def test_whitened_v_tells_its_frame():
    from roa.proof._whiten import Whitened, whitening_for

    system = vanderpol()
    V = roa.default_lyapunov(system)
    M = whitening_for(V)
    assert M is not None
    W = Whitened(V, system, M)
    base, sys_, frame = W.unwhitened()
    assert base is V and sys_ is system and np.array_equal(frame, M)
    assert W.quadratic_view() is None  # W is V(c + M y), not written as a quadratic form
    assert W.is_polynomial  # its exact coefficients in y (quadratic base: a Gram matrix in y)


# -- validators and proposers declare what they can do ------------------------------------------------
def test_validators_declare_their_capabilities():
    system = vanderpol()
    V = roa.default_lyapunov(system)
    assert IntervalValidator().refutes and AutoValidator().refutes
    assert not SosValidator().refutes and SosValidator().exact_only
    assert isinstance(SosValidator().refuter(), IntervalValidator)
    assert IntervalValidator().refuter() == IntervalValidator()
    assert (
        AutoValidator(max_bnb_dim=7).max_bnb_dim == 7 and IntervalValidator().max_bnb_dim == BNB_DIM
    )
    # 2 states: the branch and bound goes first, no exact route before it
    assert AutoValidator().exact_route(system, V) is None
    assert AutoValidator(max_bnb_dim=1).exact_route(system, V) is not None
    assert SosValidator().exact_route(system, V) is not None
    assert not AutoValidator().without_witness_search().witness_search  # type: ignore[attr-defined]
    # the ray cover is taken by the branch and bound only, and computed only then
    calls = []

    def half():
        calls.append(1)
        return np.ones(2)

    assert SosValidator().with_cover(half) == SosValidator() and not calls
    covered = IntervalValidator().with_cover(half)
    assert calls == [1] and np.array_equal(covered.bounding_box, 1.3 * np.ones(2))  # type: ignore[attr-defined]
    given = IntervalValidator(bounding_box=np.ones(2))
    assert given.with_cover(half) is given and calls == [1]


class _Only:
    """A validator object with only a name, accepts and check: the branch and bound inside."""

    name = "only"

    def accepts(self, system, V):
        return True

    def check(self, system, V, level):
        return IntervalValidator().check(system, V, level)


def test_a_plain_validator_object_gets_the_default_capabilities():
    v = as_validator(_Only())
    assert isinstance(v, Declared) and v.refutes and v.max_bnb_dim == BNB_DIM
    assert v.exact_route(vanderpol(), roa.default_lyapunov(vanderpol())) is None
    assert roa.certify(vanderpol(), level=2.30, validator=_Only()).certified
    refuted = roa.certify(vanderpol(), level=2.31, validator=_Only())
    assert refuted.status is Verdict.REFUTED


def test_proposers_declare_given_fallback_and_their_form_over_a_box():
    assert GivenLevel(1.0).given and not SampledLevel().given
    assert SampledLevel().fallback and not SosLevel().fallback
    for p in (GivenLevel(1.0), CandidateLevel(1.0), WorstCase(SampledLevel())):
        assert p.over_box() is p
    for p in (SampledLevel(), SosLevel()):
        box = p.over_box()
        assert isinstance(box, WorstCase) and box.inner is p


def test_sources_of_v_are_recognised_by_their_protocol():
    assert isinstance(roa.VsIteration(), VSource) and isinstance(roa.CuttingPlanes(), VSource)
    assert not isinstance(roa.default_lyapunov(vanderpol()), VSource)


# -- the back-off reads the reason, not the message ---------------------------------------------------
class _Recorder:
    name = "recorder"

    def __init__(self) -> None:
        self.levels: list[float] = []

    def accepts(self, system, V):
        return True

    def check(self, system, V, level):
        self.levels.append(level)
        return Validation(Verdict.INCONCLUSIVE, level, 0, 0.0, message="budget")


def _back_off(reason: Reason, message: str) -> list[float]:
    rec = _Recorder()
    box = SimpleNamespace(parameters={"a": (0.0, 1.0)})  # a parameter box: the back-off applies
    run = Run(box, None, as_validator(rec), RetryPolicy(), WitnessRefuter(), 0.0)  # type: ignore[arg-type]
    first = Validation(Verdict.INCONCLUSIVE, 1.0, 0, 0.0, message=message, reason=reason)
    RetryPolicy().back_off(run, Attempt(first, 1.0, 1.0))
    return rec.levels


@pytest.mark.parametrize("reason", [Reason.DOMAIN, Reason.NO_COVER])
def test_back_off_stops_on_a_domain_or_cover_reason_whatever_the_message(reason):
    assert _back_off(reason, "budget exhausted") == []


def test_back_off_goes_on_for_any_other_reason_whatever_the_message():
    # the message names a box cover, the reason does not: the reason decides
    levels = _back_off(Reason.UNSPECIFIED, "no proved box cover of the level set")
    assert levels == pytest.approx([0.98, 0.98 * 0.95, 0.98 * 0.95 * 0.9], rel=1e-15)


def test_retry_policy_checks_its_retries():
    with pytest.raises(roa.RoaInputError, match=r"retries must be an integer in \[0, 10\]"):
        RetryPolicy(11)
    with pytest.raises(roa.RoaInputError, match="retries"):
        RetryPolicy(True)  # type: ignore[arg-type]


def test_the_validations_reason_is_set_where_the_verdict_is_made():
    from roa.proof._validate import validate_level

    system = vanderpol()
    V = PolynomialLyapunov(
        [[2, 0], [0, 2]], [1.0, 1.0], [0.0, 0.0]
    )  # no Gram matrix: no global cover
    # a bounding box whose faces lie inside the level set (V = 0.01 there): no proved cover
    v = validate_level(system, V, 0.5, bounding_box=np.full(2, 0.1), cover_estimate=ray_box)
    assert v.status is Verdict.INCONCLUSIVE and v.reason is Reason.NO_COVER


# -- the proof/search boundary ------------------------------------------------------------------------
def test_a_proposed_witness_is_proved_and_a_tampered_one_refused():
    from roa.proof._witness import confirmed_bound
    from roa.search._witness import lowest_confirmed_witness

    system = vanderpol()
    V = roa.default_lyapunov(system)
    refuted = roa.certify(system, level=2.31)
    assert refuted.status is Verdict.REFUTED and refuted.validation is not None
    w = np.asarray(refuted.validation.witness, dtype=float)
    val, x, check = lowest_confirmed_witness(system, V, w)
    assert x is not None and check is not None and check["confirmed"]
    # 2.30 is certified (no witness below it) and the witness came from {V <= 2.31}
    assert 2.30 <= val <= 2.31
    assert confirmed_bound(system, V, x) == (val, check)
    inside = np.asarray(V.center) + 0.1 * (x - np.asarray(V.center))  # V' < 0 there
    assert confirmed_bound(system, V, inside) is None


def test_proof_neither_optimises_nor_samples():
    """roa.proof checks proposed points and levels; optimisers and random samples are in
    roa.search (import-linter cannot forbid a subpackage of an external package nor an
    attribute, so this scan does)."""
    found = []
    for path in sorted((ROOT / "roa" / "proof").rglob("*.py")):
        for n in ast.walk(ast.parse(path.read_text())):
            if isinstance(n, ast.Attribute) and n.attr in ("random", "default_rng"):
                found.append(f"{path.relative_to(ROOT)}:{n.lineno}: {n.attr}")
            names = []
            if isinstance(n, ast.Import):
                names = [a.name for a in n.names]
            elif isinstance(n, ast.ImportFrom) and n.module:
                names = [n.module] + [f"{n.module}.{a.name}" for a in n.names]
            if any(m == "scipy.optimize" or m.startswith("scipy.optimize.") for m in names):
                found.append(f"{path.relative_to(ROOT)}:{n.lineno}")
    assert not found, found
