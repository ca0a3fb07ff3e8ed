"""The ``objectplaces`` command line.

Subcommands are plugins: each package that offers one declares an entry point in the
``objectplaces.commands`` group (see ``pyproject.toml``). That keeps the import arrows
pointing one way: the middleware never imports the AGV application or the dashboard,
yet ``objectplaces sim`` and ``objectplaces demo`` are found when those are installed.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from importlib.metadata import entry_points

from objectplaces.extras import missing_extra

__all__ = ["COMMAND_GROUP", "build_parser", "main"]

COMMAND_GROUP = "objectplaces.commands"

Register = Callable[["argparse._SubParsersAction[argparse.ArgumentParser]"], None]


def build_parser() -> argparse.ArgumentParser:
    """Build the top-level parser with every installed subcommand registered.

    Returns:
        The parser; each subcommand sets ``func(args) -> int`` as its default.
    """
    parser = argparse.ArgumentParser(
        prog="objectplaces",
        description=(
            "ObjectPlaces: roles and interaction sessions among mobile nodes, "
            "and a simulated AGV fleet that uses them."
        ),
    )
    subcommands = parser.add_subparsers(title="commands", metavar="COMMAND")
    for entry in sorted(entry_points(group=COMMAND_GROUP), key=lambda e: e.name):
        try:
            register: Register = entry.load()
        except ImportError as exc:
            # Its extra is not installed (or the plugin is broken): the command stays
            # listed, and says what to install when it is run.
            _unavailable(subcommands, entry.name, exc, entry.extras)
            continue
        except AttributeError as exc:
            # One broken plugin must not take the other commands down with it.
            print(f"objectplaces: command {entry.name!r} unavailable: {exc}", file=sys.stderr)
            continue
        register(subcommands)
    return parser


def _unavailable(
    subcommands: argparse._SubParsersAction[argparse.ArgumentParser],
    name: str,
    exc: ImportError,
    extras: Sequence[str],
) -> None:
    """Register ``name`` as a command that fails at once, saying which extra it needs
    (the one its entry point declares, else the one of the module found missing)."""
    if extras:
        reason = f"objectplaces {name} needs pip install 'objectplaces[{extras[0]}]' ({exc})"
    elif isinstance(exc, ModuleNotFoundError):
        reason = str(missing_extra(exc, f"objectplaces {name}"))
    else:
        reason = f"objectplaces {name} is unavailable: {exc}"
    hint = f"pip install 'objectplaces[{extras[0]}]'" if extras else "what is missing"
    sub = subcommands.add_parser(name, help=f"(needs {hint})", add_help=False)
    sub.set_defaults(unavailable=reason)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line.

    Args:
        argv: arguments without the program name; ``sys.argv[1:]`` when None.

    Returns:
        The process exit status.
    """
    parser = build_parser()
    args, unknown = parser.parse_known_args(argv)
    unavailable: str | None = getattr(args, "unavailable", None)
    if unavailable is not None:  # its extra is missing: say which, whatever the options
        print(unavailable, file=sys.stderr)
        return 2
    if unknown:
        parser.error(f"unrecognized arguments: {' '.join(unknown)}")
    # A command that starts itself again in another process (``sim --compiled``)
    # passes on the arguments it was given.
    args.command_line = list(argv) if argv is not None else sys.argv[1:]
    func: Callable[[argparse.Namespace], int] | None = getattr(args, "func", None)
    if func is None:
        parser.print_help()
        return 2
    try:
        return func(args)
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
