"""``roa verify``: prove a certificate file again for a system, by interval validation."""

from __future__ import annotations

import argparse

from roa.commands import _common as C
from roa.io import to_json


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "verify",
        help="re-verify a certificate file (roa certify --json) for a system",
        description="Read CERT.json as a claim (its V and level; its status is not believed), "
        "check it is for --system as loaded (system_fingerprint) and prove it again by interval "
        "validation. Exit 0 when certified, 1 when not, 2 on bad input.",
    )
    p.add_argument("certificate", metavar="CERT.json", help="the JSON of roa certify --json")
    C.add_system(p)
    p.add_argument("--json", action="store_true", help="print the re-verification as JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from roa.certification._files import read_certificate_json
    from roa.certification._result import Certificate

    system = C.system(args)
    where = f"certificate {args.certificate}"
    claim = Certificate.from_dict(read_certificate_json(args.certificate, where), system,
                                  where=where)  # fmt: skip
    proof = claim.reverify()
    if args.json:
        print(to_json({**proof.to_dict(), "claimed_status": claim.status.value}))
    else:
        print(f"{system.name}: {claim.V.name if claim.V else 'V'} <= {claim.level:.6g}: "
              f"{proof.status.value} (claimed {claim.status.value}); {proof.message}")  # fmt: skip
    return 0 if proof.certified else 1
