"""``wheelleg new-robot NAME``: write a robot package's skeleton (hil/scaffold/), ready to pip install."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from wheelleg.hil import robots, scaffold

NAME = "new-robot"
HELP = "write the skeleton of a robot package (a working two-wheeled balancer to edit into your robot)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("name", help="the robot's name (lower case, words joined by '-'), e.g. my-robot")
    parser.add_argument("--dir", type=Path, default=None,
                        help="where to write the package (default: ./wheelleg-NAME); must be new or empty")


def run(args: argparse.Namespace) -> int:
    directory = args.dir if args.dir is not None else Path(f"wheelleg-{args.name}")
    if args.name in robots.names():
        print(f"wheelleg new-robot: a robot named {args.name!r} is installed already (package "
              f"{robots.origin(args.name)}): choose another name", file=sys.stderr)
        return 2
    try:
        written = scaffold.write(args.name, directory)
    except ValueError as exc:
        print(f"wheelleg new-robot: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"wheelleg new-robot: {exc.filename or directory}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    package = scaffold.placeholders(args.name)["package"]
    print(f"wrote {len(written)} files of the {args.name} robot into {directory}/ (package {package})\n"
          f"next:\n  pip install -e {directory}\n  wheelleg list --robot {args.name}\n"
          f"  wheelleg run {args.name}/balance --out out/\n"
          f"then make it yours: docs/your-robot.md of wheelleg-hil")
    return 0
