"""``wheelleg``: the rig's one command line, one module per subcommand.

Each module in ``hil/commands/`` exposes ``NAME``, ``HELP``, ``add_arguments``
and ``run(args) -> int`` (cantools' layout); the table below wires them in.
"""
from __future__ import annotations

import argparse
import importlib
import sys

SUBCOMMANDS = ("run", "list", "campaign", "emulate", "controller", "replay", "inspect", "vcan")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="wheelleg", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    for name in SUBCOMMANDS:
        try:
            module = importlib.import_module(f"wheelleg.hil.commands.{name.replace('-', '_')}")
        except ModuleNotFoundError as exc:
            if exc.name != f"wheelleg.hil.commands.{name}":
                raise
            continue  # subcommand not built yet
        p = sub.add_parser(module.NAME, help=module.HELP, description=module.HELP)
        module.add_arguments(p)
        p.set_defaults(func=module.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
