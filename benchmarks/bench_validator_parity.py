"""Parity of the two interval validators: the quadratic loop vs the general one, on the same V.

Run: ``python benchmarks/bench_validator_parity.py [--repeats 3] [--direct]``.

The quadratic path is :func:`roa.proof.validate.validate_level` on the system's default
:class:`~roa.lyapunov.QuadraticLyapunov` (whitened boxes, closed-form V). The general path is the
same V written as a degree-2 :class:`~roa.lyapunov.PolynomialLyapunov` (the monomials of
``d' P d``, ``d = x - x_eq``, from the Gram matrix ``P`` over the linear monomials), which
``validate_level`` hands to :func:`roa.proof.validate_general.validate_general` (the whitened
branch and bound with the multiplier test and the component check). ``--direct`` adds
``validate_general`` called on the quadratic V itself (whitened through ``x``, no expanded
polynomials).

Cases: Van der Pol with its default V at 2.30 (certified) and 2.31 (refuted); the IPC paper's V in
flat coordinates (``ipc-flat``) at 2.28 (certified) and 2.29 (refuted). Boxes are the branch and
bound's box evaluations; ``cover`` is the general path's extra boxes proving its box cover of the
level set (``V > level`` on its faces); the box ratio is general (B&B + cover) / quadratic.
Seconds are wall time around each call, the minimum over the repeats (median printed too).
Target: general within 1.5x of quadratic in boxes and time, same verdicts (exit 1 if a verdict
differs).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import roa
from roa.lyapunov import PolynomialLyapunov, QuadraticLyapunov
from roa.proof.validate import validate_level
from roa.proof.validate_general import validate_general
from roa.systems.vanderpol import vanderpol

CASES = (
    ("vanderpol", vanderpol, (2.30, 2.31)),
    ("ipc-flat", lambda: roa.load_system("ipc-flat"), (2.28, 2.29)),
)


def as_polynomial(V: QuadraticLyapunov) -> PolynomialLyapunov:
    """``V = d' P d`` as a degree-2 polynomial: the Gram matrix ``P`` over the linear monomials."""
    basis = [tuple(int(i == j) for i in range(V.n)) for j in range(V.n)]
    return PolynomialLyapunov.from_gram(basis, V.P, V.center, name=f"{V.name} (polynomial)")


def timed(fn, repeats: int):
    """The last result and the wall times of ``repeats`` calls."""
    secs = []
    for _ in range(repeats):
        t = time.perf_counter()
        res = fn()
        secs.append(time.perf_counter() - t)
    return res, secs


def main() -> None:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--repeats", type=int, default=3, help="calls per path and case (min taken)")
    ap.add_argument("--direct", action="store_true", help="also validate_general on quadratic V")
    args = ap.parse_args()
    validate_level(vanderpol(), roa.default_lyapunov(vanderpol()), 1.0)  # warm imports
    head = (
        f"{'case':<10} {'level':>5} {'path':<8} {'verdict q/g':<21} {'boxes q':>8} "
        f"{'boxes g':>8} {'cover':>7} {'ratio':>6} {'s q min':>8} {'s g min':>8} "
        f"{'s q med':>8} {'s g med':>8} {'ratio':>6}"
    )
    print(head)
    differ = []
    for name, make, levels in CASES:
        system = make()
        V = roa.default_lyapunov(system)
        paths = [("poly", as_polynomial(V), validate_level)]
        if args.direct:
            paths.append(("direct", V, validate_general))
        for level in levels:
            q, sq = timed(lambda: validate_level(system, V, level), args.repeats)  # noqa: B023
            for label, W, fn in paths:
                g, sg = timed(lambda: fn(system, W, level), args.repeats)  # noqa: B023
                cover = int(g.meta.get("cover_boxes", 0))
                verdicts = f"{q.status.value}/{g.status.value}"
                if q.status != g.status:
                    differ.append(f"{name} {level} {label}: {verdicts}")
                print(
                    f"{name:<10} {level:>5.2f} {label:<8} {verdicts:<21} {q.boxes:>8} "
                    f"{g.boxes:>8} {cover:>7} {(g.boxes + cover) / q.boxes:>6.2f} "
                    f"{min(sq):>8.3f} {min(sg):>8.3f} {statistics.median(sq):>8.3f} "
                    f"{statistics.median(sg):>8.3f} {min(sg) / min(sq):>6.2f}"
                )
    if differ:
        print("verdicts differ: " + "; ".join(differ))
        sys.exit(1)


if __name__ == "__main__":
    main()
