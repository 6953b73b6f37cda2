"""A program as a command the rig starts as its own process on the buses, and stops at the end.

The command is shell words (``shlex``), run without a shell, in its own process
group (what it starts is stopped with it). The two channels reach it through
placeholders in its words: ``{can1}`` (CAN1: wheels, IMU, remote), ``{can2}``
(CAN2: the joints) and ``{interface}`` (python-can's interface name); a command
with none of them gets the two channel names appended (``wheelleg-fw --sync``
-> ``wheelleg-fw --sync vcan0 vcan1``). ``{{`` and ``}}`` are literal braces.

Its stdout and stderr go to one file (``NAME.program.log`` beside the trace);
when it exits before the run ends, the run records the exit status and the
file's tail. At the end: SIGTERM to its group, SIGKILL after ``GRACE_S``.
"""
from __future__ import annotations

import os
import shlex
import shutil
import signal
import subprocess
import time
from pathlib import Path

from wheelleg.dbc import CAN1, CAN2
from wheelleg.hil.program.library import ProgramError

GRACE_S = 2.0  # s between SIGTERM and SIGKILL at the end of a run
START_S = 30.0  # s a program the rig started has to open its buses and answer (Python under user-mode-linux: 5-15 s)
TAIL_LINES = 8  # lines of the program's output a report quotes
PLACEHOLDERS = ("can1", "can2", "interface")
SOCKET_SETTLE_S = 0.05  # s between a program's opening its bus sockets and the run's first frame


class ProgramExited(RuntimeError):
    """The program's process ended before the run did (``status``: its exit status, -N: killed by signal N)."""

    def __init__(self, status: int, tail: str, at_s: float):
        self.status, self.tail, self.at_s = status, tail, at_s
        super().__init__(f"the program exited with status {status} at {at_s:.3f} s"
                         + (f"; its output ends: {tail_line(tail)}" if tail else ""))


def split_command(text: str) -> list[str]:
    """The command's words; ValueError (one line) for an empty or unbalanced one, or an unknown placeholder."""
    try:
        words = shlex.split(text)
    except ValueError as exc:
        raise ValueError(f"program command {text!r}: {exc}") from None
    if not words:
        raise ValueError("program command is empty")
    for word in words:
        try:
            word.format(**{k: "" for k in PLACEHOLDERS})
        except (KeyError, IndexError, ValueError) as exc:
            raise ValueError(f"program command {text!r}: bad placeholder in {word!r} ({exc}); "
                             f"known: {', '.join('{' + p + '}' for p in PLACEHOLDERS)}") from None
    if shutil.which(words[0]) is None:
        raise ValueError(f"program command {text!r}: {words[0]!r} is not an executable file or on PATH")
    return words


def command_argv(words: list[str], interface: str, channels: dict[str, str]) -> list[str]:
    """``words`` with the placeholders filled, or the two channels appended when it has none."""
    values = {"can1": channels[CAN1], "can2": channels[CAN2], "interface": interface}
    if not any("{" + p + "}" in w for w in words for p in PLACEHOLDERS):
        return [w.replace("{{", "{").replace("}}", "}") for w in words] + [channels[CAN1], channels[CAN2]]
    return [w.format(**values) for w in words]


def tail_line(tail: str) -> str:
    """The tail of the program's output on one line (for one-line errors and check details)."""
    return " | ".join(line.strip() for line in tail.splitlines() if line.strip())


class ProgramProcess:
    """The program's process: ``start``, ``exited`` (poll), ``stop``; output in ``log_path``."""

    def __init__(self, argv: list[str], log_path: Path):
        self.argv, self.log_path = argv, Path(log_path)
        self.proc: subprocess.Popen | None = None
        self.status: int | None = None

    def start(self) -> None:
        with open(self.log_path, "wb") as log:
            try:
                self.proc = subprocess.Popen(self.argv, stdin=subprocess.DEVNULL, stdout=log, stderr=log,
                                             start_new_session=True)
            except OSError as exc:
                raise ProgramError(f"program command {shlex.join(self.argv)}: cannot start ({exc.strerror})") from None

    def exited(self) -> int | None:
        """Its exit status if it has ended (-N: killed by signal N), else None."""
        if self.proc is None:
            return None
        if self.status is None:
            self.status = self.proc.poll()
        return self.status

    def stop(self, grace_s: float = GRACE_S) -> int | None:
        """SIGTERM to its process group, SIGKILL after ``grace_s``; its exit status."""
        if self.proc is None:
            return None
        if self.exited() is None:
            self._signal(signal.SIGTERM)
            try:
                self.status = self.proc.wait(grace_s)
            except subprocess.TimeoutExpired:
                self._signal(signal.SIGKILL)
                self.status = self.proc.wait()
        self._signal(signal.SIGKILL)  # whatever it left behind in its group
        return self.status

    def _signal(self, sig: int) -> None:
        try:
            os.killpg(self.proc.pid, sig)
        except (ProcessLookupError, PermissionError):
            pass

    def tail(self, lines: int = TAIL_LINES) -> str:
        """The last ``lines`` lines of its output."""
        try:
            text = self.log_path.read_bytes()[-8192:].decode("utf-8", "replace")
        except OSError:
            return ""
        return "\n".join(text.splitlines()[-lines:])

    def sockets(self) -> int:
        """Sockets open in its process and the processes it started (Linux ``/proc``; 0 elsewhere)."""
        count, pids, seen = 0, [self.proc.pid] if self.proc is not None else [], set()
        while pids:
            pid = pids.pop()
            if pid in seen:
                continue
            seen.add(pid)
            fd_dir = Path(f"/proc/{pid}/fd")
            try:
                count += sum(1 for fd in fd_dir.iterdir() if os.readlink(fd).startswith("socket:"))
                for task in Path(f"/proc/{pid}/task").iterdir():
                    pids += [int(c) for c in (task / "children").read_text().split()]
            except OSError:  # it ended meanwhile, or no /proc
                continue
        return count

    def await_sockets(self, count: int, timeout_s: float) -> bool:
        """Whether it opened ``count`` sockets (its buses) within ``timeout_s``, then ``SOCKET_SETTLE_S``
        more for it to bind them: a frame sent to a bus before it listens is lost to it."""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end and self.exited() is None:
            if self.sockets() >= count:
                time.sleep(SOCKET_SETTLE_S)
                return True
            time.sleep(0.005)
        return False
