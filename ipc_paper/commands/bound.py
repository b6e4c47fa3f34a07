"""``roa study ipc bound``: the analytic bound (3.13)-(3.14) as printed and corrected."""

from __future__ import annotations

import argparse

from roa.io import to_json


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bound", help="the paper's analytic bound c~ (3.14), printed and corrected")
    p.add_argument(
        "--json", action="store_true", help="print one JSON object (keys paper, corrected)"
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ipc_paper.bound import corrected_bound, paper_bound

    out = {"paper": paper_bound(), "corrected": corrected_bound()}
    if args.json:
        print(to_json(out))
        return 0
    for name, b in out.items():
        print(
            f"{name}: kappa = {b['kappa']:.6f}, alpha <= {b['alpha_max']:.6f} ({b['alpha_max_expr']}), "
            f"c~ = {b['c_tilde']:.6f} ({b['c_tilde_expr']})"
        )
        print(
            f"  {'implies' if b['argument_valid'] else 'would imply (argument invalid)'}: "
            f"V < {b['V_level_in_slab']:.6f} (largest V-level in the slab q4^2 < c~), "
            f"ball ||q||^2 < {b['ball_in_V_level']:.6f}; {b['status']}"
        )
    return 0
