"""``objectplaces pki``: the fleet's certificate authority on the command line.

```sh
objectplaces pki init --dir fleet-pki --fleet plant1
objectplaces pki issue --dir fleet-pki agv-01 --role agv
objectplaces pki issue --dir fleet-pki router-1 --role router --address 10.0.0.2
objectplaces pki revoke --dir fleet-pki agv-01
objectplaces pki list --dir fleet-pki
```

A credential that cannot be made or used is named with its path and the reason, and
the command exits with status 2.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from objectplaces.arguments import whole
from objectplaces.security import ROLES, CredentialError, init_ca, issue, issued, revoke

__all__ = ["register", "run_pki"]


def register(subcommands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``pki`` subcommand to the ``objectplaces`` command line."""
    parser = subcommands.add_parser(
        "pki",
        help="the fleet's certificate authority: init, issue, revoke, list",
        description="Make the fleet CA, issue a certificate per member, revoke one.",
    )
    actions = parser.add_subparsers(title="actions", dest="action", metavar="ACTION")
    actions.required = True
    init = actions.add_parser("init", help="make the fleet CA in a new folder")
    init.add_argument("--fleet", default="default", help="the fleet's name")
    add = actions.add_parser("issue", help="issue a certificate and key for a member")
    add.add_argument("node_id", metavar="ID", help="the member's id")
    add.add_argument("--role", choices=ROLES, default="node", help="the member's role")
    add.add_argument("--days", type=whole(at_least=1), default=365, help="validity, days")
    add.add_argument(
        "--address",
        action="append",
        default=[],
        help="a host name or IP address the member serves on (routers); repeatable",
    )
    gone = actions.add_parser("revoke", help="revoke a member's certificate")
    gone.add_argument("node_id", metavar="ID", help="the member's id")
    actions.add_parser("list", help="list the certificates issued")
    for sub in (init, add, gone, actions.choices["list"]):
        sub.add_argument("--dir", type=Path, required=True, help="the PKI folder")
        sub.set_defaults(func=run_pki)


def run_pki(args: argparse.Namespace) -> int:
    """Run one ``pki`` action; 2 when a credential cannot be made or used."""
    directory: Path = args.dir
    try:
        match args.action:
            case "init":
                path = init_ca(directory, fleet=args.fleet)
                print(f"fleet CA {args.fleet!r}: {path} (its key in {directory / 'private'})")
            case "issue":
                cert, key = issue(
                    directory,
                    args.node_id,
                    role=args.role,
                    days=args.days,
                    addresses=tuple(args.address),
                )
                print(f"{args.node_id} ({args.role}): {cert}, {key}")
            case "revoke":
                done = revoke(directory, args.node_id)
                print(f"{done.node_id}: serial {done.serial} revoked at {done.revoked}")
            case "list":
                for entry in issued(directory):
                    state = f"revoked {entry.revoked}" if entry.revoked else "valid"
                    print(f"{entry.node_id}\t{entry.role}\tuntil {entry.not_after}\t{state}")
    except CredentialError as exc:
        print(f"objectplaces pki: {exc}", file=sys.stderr)
        return 2
    return 0
