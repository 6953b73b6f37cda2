"""``wheelleg``: the rig's one command line, one module per subcommand.

Each module in ``hil/commands/`` exposes ``NAME``, ``HELP``, ``add_arguments``
and ``run(args) -> int`` (cantools' layout); the table below wires them in.

Exit status, the same for every subcommand: 0 done (every check passed),
1 failed (a check, a comparison, a bus that cannot be opened), 2 bad input
(usage: an unknown name, a bad value, an output that cannot be written),
130 interrupted (Ctrl-C), 143 stopped by SIGTERM (cleaned up as after Ctrl-C), 141 the reader of the output went away (``| head``).
"""
from __future__ import annotations

import argparse
import importlib
import importlib.metadata
import os
import signal
import sys
import threading
import time
import warnings

# The command's clock starts when this module loads: importing the rig (MuJoCo, numpy,
# cantools) and building the model count as the run's start-up (`wheelleg run` prints it).
# A process that calls ``main`` again (a test, a worker) starts each later command's clock
# at its call: the imports were the first command's.
STARTED_S = time.perf_counter()
_IMPORTS_COUNTED = False

SUBCOMMANDS = ("run", "list", "campaign", "margins", "emulate", "controller", "replay", "diff", "inspect", "decode",
               "export", "recover", "vcan", "new-robot", "render", "layout")


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser of every subcommand (``command`` None), or of ``command`` alone.

    With ``command`` only its module is imported: each pulls in what it needs
    (``run`` the rig: MuJoCo, numpy, cantools, ~0.5 s; ``decode`` ~0.1 s), so
    ``wheelleg decode`` or ``wheelleg controller`` on the robot does not wait for
    the rig. The others stay as names without options, so a wrong name is still
    told the whole list.
    """
    parser = argparse.ArgumentParser(prog="wheelleg", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"%(prog)s {version()}")
    sub = parser.add_subparsers(dest="command", required=True)
    for name in SUBCOMMANDS:
        if command is not None and name != command:
            sub.add_parser(name)
            continue
        module = importlib.import_module(f"wheelleg.hil.commands.{name.replace('-', '_')}")
        p = sub.add_parser(module.NAME, help=module.HELP, description=module.HELP)
        module.add_arguments(p)
        p.set_defaults(func=module.run)
    return parser


def named_command(argv: list[str]) -> str | None:
    """The subcommand ``argv`` names (its first word that is not an option), None if none does."""
    first = next((arg for arg in argv if not arg.startswith("-")), None)
    return first if first in SUBCOMMANDS else None


def version() -> str:
    """The installed distribution's version (``wheelleg-hil``)."""
    try:
        return importlib.metadata.version("wheelleg-hil")
    except importlib.metadata.PackageNotFoundError:  # run from a source tree that was never installed
        return "unknown (not installed)"


_FORMAT_WARNING = warnings.formatwarning


def one_line_warning(message, category, filename, lineno, line=None) -> str:
    """A broken robot plug-in (``wheelleg.hil.robots.RobotPluginWarning``) is one line on stderr, not Python's
    two with the source line of the rig that noticed it; every other warning as Python writes it."""
    if category.__name__ == "RobotPluginWarning":
        return f"wheelleg: warning: {message}\n"
    return _FORMAT_WARNING(message, category, filename, lineno, line)


def main(argv: list[str] | None = None) -> int:
    global STARTED_S, _IMPORTS_COUNTED
    if _IMPORTS_COUNTED:
        STARTED_S = time.perf_counter()
    _IMPORTS_COUNTED = True
    warnings.formatwarning = one_line_warning
    # No subcommand renders: without this MuJoCo loads an OpenGL back end (glfw) on import, ~0.3 s
    # of every command's start-up. A value the user set is kept.
    os.environ.setdefault("MUJOCO_GL", "disable")
    argv = sys.argv[1:] if argv is None else argv
    args = build_parser(named_command(argv)).parse_args(argv)
    previous = terminate_as_interrupt()
    try:
        status = int(args.func(args) or 0)
        sys.stdout.flush()  # a closed pipe shows here, inside the handler, not at interpreter exit
        return status
    except Terminated:
        return 128 + signal.SIGTERM
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:  # `wheelleg ... | head -1`: the reader left; the files are written already
        # Python would complain again flushing stdout at exit: point it at /dev/null first.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


class Terminated(KeyboardInterrupt):
    """SIGTERM (a CI job cancelled, ``timeout``, a process manager), raised in the main thread.

    A KeyboardInterrupt, so whatever cleans up after Ctrl-C (the rig closing and indexing its
    trace, flushing its log, a campaign's journal) does the same after SIGTERM, and a command
    that says where it stopped says so for both.
    """


def _raise_terminated(signum, frame):
    raise Terminated(f"stopped by signal {signal.Signals(signum).name}")


def terminate_as_interrupt():
    """SIGTERM raises ``Terminated`` in the main thread from now on; the previous handler, or None
    when not in the main thread (signals can only be handled there: nothing changed)."""
    if threading.current_thread() is not threading.main_thread():
        return None
    return signal.signal(signal.SIGTERM, _raise_terminated)


if __name__ == "__main__":
    sys.exit(main())
