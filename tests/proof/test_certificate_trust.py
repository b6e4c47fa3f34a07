"""Certificates are re-verified where they are used: a forged or mismatched certificate file never
turns diverging runs into converged ones (reliability issue, items 1 and 2).

Van der Pol (mu = 1, the benchmark P): {V <= 2.30} is certified, the published optimum is 2.3045,
so every level edited above it is false and must be refused; mu = 15 is another system, whose
certificate the mu = 1 file is not. Each tampered file below is one of the adversarial run's
findings; each was accepted before re-verification (the basin then counted diverging runs as
converged).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import roa
import roa.io
from roa.cli import main
from roa.errors import RoaInputError
from roa.model._fingerprint import system_fingerprint
from roa.montecarlo._certified_set import terminal_from_certificate
from roa.proof._reverify import content_key, reverify
from roa.search._rays import ray_box
from roa.systems.vanderpol import P_BENCHMARK, vanderpol

LEVEL = 2.30


@pytest.fixture(autouse=True)
def _private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("ROA_CACHE_DIR", str(tmp_path / "cache"))


@pytest.fixture(scope="module")
def certificate() -> dict:
    cert = roa.certify(vanderpol(), level=LEVEL)
    assert cert.certified
    return json.loads(roa.io.to_json(cert.to_dict()))


def _quadratic_form(P: np.ndarray) -> dict:
    return {"lyapunov": "q", "kind": "PolynomialLyapunov", "degree": 2,
            "monomials": [[2, 0], [1, 1], [0, 2]],
            "coefficients": [P[0, 0], 2 * P[0, 1], P[1, 1]]}  # fmt: skip


TAMPERED = {
    "level 1000": lambda c: {**c, "level": 1000.0},
    "level 1e308": lambda c: {**c, "level": 1e308},
    "level just above the optimum": lambda c: {**c, "level": 2.31},
    "P scaled by 1e-3": lambda c: {**c, "P": (np.asarray(c["P"]) * 1e-3).tolist()},
    "indefinite P": lambda c: {**c, "P": [[1.0, 0.0], [0.0, -1.0]]},
    "forged polynomial": lambda c: {
        **{k: v for k, v in c.items() if k != "P"},
        "candidate_kind": _quadratic_form(np.asarray(c["P"]) * 1e-3),
    },
    "polynomial centred elsewhere": lambda c: {
        **{k: v for k, v in c.items() if k != "P"},
        "candidate_kind": {**_quadratic_form(np.asarray(c["P"])), "center": [0.5, 0.0]},
    },
}


@pytest.mark.parametrize("edit", list(TAMPERED))
def test_tampered_certificates_are_refused(certificate, edit):
    forged = TAMPERED[edit](certificate)
    with pytest.raises(RoaInputError, match="terminal set"):
        terminal_from_certificate(forged, vanderpol())


def test_the_genuine_certificate_is_proved_again_and_remembered_by_content(certificate):
    system = vanderpol()
    term = terminal_from_certificate(certificate, system)
    assert term.quadratic and term.level == LEVEL
    np.testing.assert_array_equal(term.P, P_BENCHMARK)
    moved = terminal_from_certificate({**certificate, "center": [5.0, 5.0]}, system)
    np.testing.assert_array_equal(moved.center, system.x_eq)  # the file cannot move the centre
    V = roa.default_lyapunov(system)
    again = reverify(system, V, LEVEL, cover_estimate=ray_box)
    assert again.certified and again.cached  # the first use proved it; the key is the content
    assert not reverify(
        system, V, 2.31, cover_estimate=ray_box
    ).certified  # refuted: never cached, never certified
    assert content_key(system, V, LEVEL) != content_key(system, V, np.nextafter(LEVEL, 3.0))
    assert content_key(system, V, LEVEL) != content_key(vanderpol(mu=1.5), V, LEVEL)


def test_a_certificate_of_another_parameter_is_refused(certificate):
    """The mu = 1 certificate names "vanderpol" as mu = 15 does: the fingerprint tells them apart,
    and without it the re-verification on mu = 15 refuses the level."""
    stiff = roa.load_system("vanderpol:mu=15")
    assert stiff.name == certificate["system"]
    assert certificate["system_fingerprint"] == system_fingerprint(vanderpol())
    assert certificate["system_fingerprint"] != system_fingerprint(stiff)
    with pytest.raises(RoaInputError, match="another system"):
        terminal_from_certificate(certificate, stiff)
    unstamped = {k: v for k, v in certificate.items() if k != "system_fingerprint"}
    with pytest.raises(RoaInputError, match="re-verification failed"):
        terminal_from_certificate(unstamped, stiff)


def test_forged_terminal_set_leaves_basin_counts_as_without_it(certificate, tmp_path, capsys):
    """Through the CLI: the forged file is refused (exit 2, naming --terminal-set), the genuine one
    leaves every count as the run without a terminal set."""
    good, forged = tmp_path / "good.json", tmp_path / "forged.json"
    good.write_text(json.dumps(certificate))
    forged.write_text(json.dumps({**certificate, "level": 1000.0}))
    argv = ["basin", "--system", "vanderpol", "--slice", "x1,x2", "--grid", "12x12",
            "--box", "x1=-4:4,x2=-4:4", "--t-final", "20", "--jobs", "1", "--json"]  # fmt: skip
    assert main(argv) == 0
    plain = json.loads(capsys.readouterr().out)
    assert plain["counts"]["diverged"] + plain["counts"].get("undecided", 0) > 0
    assert main([*argv, "--terminal-set", str(forged)]) == 2
    err = capsys.readouterr().err
    assert "--terminal-set" in err and "re-verification failed" in err and "Traceback" not in err
    assert main([*argv, "--terminal-set", str(good)]) == 0
    with_set = json.loads(capsys.readouterr().out)
    assert with_set["counts"] == plain["counts"] and with_set["entered_certified_set"] > 0


def test_polynomial_frame_comes_from_the_reverification_not_the_file():
    """A polynomial certificate without its frame M (or with a forged one) is not built in the
    identity frame: the frame is the one of the validation that re-proved it."""
    V = roa.PolynomialLyapunov([[2, 0], [1, 1], [0, 2], [4, 0]],
                               [P_BENCHMARK[0, 0], 2 * P_BENCHMARK[0, 1], P_BENCHMARK[1, 1], 0.05],
                               [0.0, 0.0], "quartic")  # fmt: skip
    cert = roa.certify(vanderpol(), V, level=1.5, method="interval")
    assert cert.certified
    data = json.loads(roa.io.to_json(cert.to_dict()))
    M = np.asarray(data["M"])
    assert not np.allclose(M, np.eye(2))
    for variant in ({k: v for k, v in data.items() if k != "M"}, {**data, "M": [[1, 0], [0, 1]]}):
        term = terminal_from_certificate(variant, vanderpol())
        np.testing.assert_array_equal(term.frame, M)


def test_a_field_using_t_undeclared_is_an_input_error(tmp_path, capsys):
    src = tmp_path / "tv.py"
    src.write_text(
        "from roa import System\n"
        "def field(t, x, xp):\n"
        "    return (-x[1] + 0.5 * t * x[0], x[0] + (x[0] ** 2 - 1) * x[1])\n"
        "SYSTEM = System(name='tv', field=field, equilibrium=(0.0, 0.0), state_names=('x1', 'x2'))\n"
    )
    with pytest.raises(RoaInputError, match=r"tv\.py.*depends on t"):
        roa.load_system(f"{src}:SYSTEM")
    assert main(["certify", "--system", f"{src}:SYSTEM", "--level", "2.3", "--json"]) == 2
    err = capsys.readouterr().err
    assert "depends on t" in err and "time_varying=True" in err and "Traceback" not in err


def test_roa_verify_proves_a_file_again_or_refuses_it(certificate, tmp_path, capsys):
    """``roa verify`` (the README's answer to deliberate edits): the genuine file is certified
    again (exit 0), the edited one is not (exit 1), whatever status the file claims."""
    good, forged = tmp_path / "good.json", tmp_path / "forged.json"
    good.write_text(json.dumps(certificate))
    forged.write_text(json.dumps({**certificate, "level": 2.31}))
    assert main(["verify", str(good), "--system", "vanderpol", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "certified" and out["claimed_status"] == "certified"
    assert main(["verify", str(forged), "--system", "vanderpol", "--json"]) == 1
    assert json.loads(capsys.readouterr().out)["status"] == "refuted"
    assert main(["verify", str(good), "--system", "vanderpol:mu=15"]) == 2
    assert "another system" in capsys.readouterr().err
    for bad, why in ((tmp_path / "none.json", "no such file"), (tmp_path, "no such file")):
        assert main(["verify", str(bad), "--system", "vanderpol"]) == 2
        assert why in capsys.readouterr().err
    (tmp_path / "list.json").write_text("[1, 2]")
    assert main(["verify", str(tmp_path / "list.json"), "--system", "vanderpol"]) == 2
    assert "expected the JSON object" in capsys.readouterr().err


def _kx13(t, x, xp, p):  # differs from -x only away from the fingerprint's trace points
    return (-x[0] + p.k * x[0] ** 13, -x[1])


def test_a_proof_is_never_served_for_another_parameter_value():
    """Review finding: the re-verification cache was keyed by the fingerprint's trace, which does
    not see k x^13 near the equilibrium: the proof for k = 0 was served for k = 10, whose level 1
    is false (x0' = -0.9 + 10 0.9^13 > 0 at (0.9, 0), inside {V <= 1})."""
    A = roa.System("toy", _kx13, (0.0, 0.0), ("a", "b"), params={"k": 0.0})
    B = A.with_params(k=10.0)
    V = roa.QuadraticLyapunov(np.eye(2), [0.0, 0.0])
    assert system_fingerprint(A) == system_fingerprint(B)  # the trace alone cannot tell them
    assert reverify(A, V, 1.0, cover_estimate=ray_box).certified
    assert reverify(B, V, 1.0, cover_estimate=ray_box).status is roa.Verdict.REFUTED
    assert content_key(A, V, 1.0) is None  # a field outside an installed package: never cached
    stiff = vanderpol().with_params(mu=1.0 + 2**-40)  # built-ins are cached, per exact parameter
    assert None is not content_key(vanderpol(), V, 1.0) != content_key(stiff, V, 1.0)
    with pytest.raises(RoaInputError, match="re-verification failed"):
        terminal_from_certificate(roa.certify(A, V, level=1.0).to_dict(), B)


def test_function_candidates_are_proved_every_time():
    """Review finding: two function V of the same name shared a cache entry."""
    system = roa.System(
        "cubic", lambda t, x, xp: (-x[0] + x[0] ** 3, -x[1]), (0.0, 0.0), ("a", "b")
    )
    Va = roa.FunctionLyapunov(lambda x, xp: x[0] ** 2 + x[1] ** 2, [0.0, 0.0], "V")
    Vb = roa.FunctionLyapunov(lambda x, xp: 0.25 * x[0] ** 2 + x[1] ** 2, [0.0, 0.0], "V")
    assert content_key(system, Va, 0.5) is None
    assert roa.certify(system, Va, level=0.5).reverify().certified
    again = roa.certify(system, Vb, level=0.5)
    assert again.status is roa.Verdict.REFUTED
    assert again.reverify().status is roa.Verdict.REFUTED


def test_a_polynomial_proved_without_whitening_is_a_terminal_set():
    """Review finding: a validation run in x recorded no frame, so its certificate could not be
    used; the frame of such a run is the identity, and it is recorded."""
    system = roa.System("lin", lambda t, x, xp: (-x[0], -x[1]), (0.0, 0.0), ("a", "b"))
    V = roa.PolynomialLyapunov([[2, 0], [0, 2], [4, 0]], [1.0, 1.0, 1.0], [0.0, 0.0])
    cert = roa.certify(system, V, level=1.0)
    assert cert.certified and cert.to_dict()["M"] == [[1.0, 0.0], [0.0, 1.0]]
    term = terminal_from_certificate(cert.to_dict(), system)
    np.testing.assert_array_equal(term.frame, np.eye(2))


# --- the proof cache's entries carry a tag (issue 39, item 3) ---------------------------------


def _entry_path(key: str):
    return roa.io.cache_dir() / "verified" / f"{key}.json"


def _verify_json(path, capsys) -> tuple[int, dict]:
    code = main(["verify", str(path), "--system", "vanderpol", "--json"])
    return code, json.loads(capsys.readouterr().out)


def test_a_hand_written_cache_entry_does_not_override_a_refutation(certificate, tmp_path, capsys):
    """Writing {"key": K, "status": "certified"} (and variants: with a validation record, with a
    made-up tag) for the refuted level 2.31 made ``roa verify`` and ``--terminal-set`` accept it;
    each verdict now equals the one with a fresh cache."""
    forged = tmp_path / "forged.json"
    forged.write_text(json.dumps({**certificate, "level": 2.31}))
    fresh_code, fresh = _verify_json(forged, capsys)  # the fresh cache's verdict
    assert fresh_code == 1 and fresh["status"] == "refuted"
    system = vanderpol()
    key = content_key(system, roa.default_lyapunov(system), 2.31)
    assert key is not None
    basin = ["basin", "--system", "vanderpol", "--slice", "x1,x2", "--grid", "4x4",
             "--box", "x1=-2:2,x2=-2:2", "--t-final", "5", "--jobs", "1", "--json",
             "--terminal-set", str(forged)]  # fmt: skip
    validation = {"status": "certified", "M": [[1.0, 0.0], [0.0, 1.0]]}
    for entry in (
        {"key": key, "status": "certified"},
        {"key": key, "status": "certified", "validation": validation},
        {"key": key, "status": "certified", "validation": validation, "tag": "0" * 64},
    ):
        _entry_path(key).parent.mkdir(parents=True, exist_ok=True)
        _entry_path(key).write_text(json.dumps(entry))
        code, out = _verify_json(forged, capsys)
        assert (code, out["status"], out.get("cached", False)) == (1, "refuted", False)
        assert main(basin) == 2
        assert "re-verification failed" in capsys.readouterr().err


def test_a_genuine_entry_is_served_and_an_edited_or_foreign_one_is_not(certificate):
    system = vanderpol()
    V = roa.default_lyapunov(system)
    assert reverify(
        system, V, LEVEL, cover_estimate=ray_box
    ).certified  # proved (or served) once: the entry exists
    assert reverify(system, V, LEVEL, cover_estimate=ray_box).cached
    path = _entry_path(content_key(system, V, LEVEL))
    entry = json.loads(path.read_text())
    assert set(entry) == {"key", "status", "validation", "tag"}
    edited = {**entry, "validation": {**entry["validation"], "M": [[2.0, 0.0], [0.0, 2.0]]}}
    path.write_text(json.dumps(edited))  # the record (its frame M) is covered by the tag
    again = reverify(system, V, LEVEL, cover_estimate=ray_box)
    assert again.certified and not again.cached and again.frame == entry["validation"]["M"]
    key_file = roa.io.cache_dir() / roa.io.SECRET_NAME
    key_file.write_bytes(bytes(roa.io.SECRET_BYTES))  # another key (still 0600, this user's)
    assert not reverify(
        system, V, LEVEL, cover_estimate=ray_box
    ).cached  # tagged under the old key: proved again
    assert reverify(system, V, LEVEL, cover_estimate=ray_box).cached  # re-tagged under the new one


@pytest.mark.parametrize("loosen", ["group-readable", "a link", "short"])
def test_a_key_file_that_cannot_be_trusted_disables_the_cache(loosen, tmp_path):
    """Nothing is served or remembered under a key others may have read or replaced."""
    import os

    system = vanderpol()
    V = roa.default_lyapunov(system)
    assert (
        reverify(system, V, LEVEL, cover_estimate=ray_box).certified
        and reverify(system, V, LEVEL, cover_estimate=ray_box).cached
    )
    key_file = roa.io.cache_dir() / roa.io.SECRET_NAME
    if loosen == "group-readable":
        os.chmod(key_file, 0o640)
    elif loosen == "a link":
        (tmp_path / "k").write_bytes(key_file.read_bytes())
        os.chmod(tmp_path / "k", 0o600)
        key_file.unlink()
        key_file.symlink_to(tmp_path / "k")
    else:
        key_file.write_bytes(key_file.read_bytes()[:16])
    assert roa.io.cache_secret() is None
    for _ in range(2):
        proof = reverify(system, V, LEVEL, cover_estimate=ray_box)
        assert proof.certified and not proof.cached
