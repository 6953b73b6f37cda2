"""Which program the rig tests (``--program P``): the Python program, a library, or a command.

- ``python`` (the default): the robot's own Python program, in-process
  (``Robot.build_controller``), lockstep in virtual time.
- ``firmware``: the repository's C firmware as a lockstep library, built on demand
  by its build function (``FIRMWARE_BUILD``); a clear error while there is none.
- a path ending in ``.so`` (or ``.so.N``, ``.dylib``), or ``lib:PATH``: a shared library
  with the lockstep C ABI (hil/program/library.py), loaded in-process with ctypes and
  run lockstep in virtual time, deterministic.
- anything else, or ``cmd:WORDS``: a command the rig starts as its own process on the
  buses and stops at the end (hil/program/process.py: placeholders ``{can1}``
  ``{can2}`` ``{interface}``, else the two channels appended). Lockstep when it
  answers SYNC with the heartbeat (``--sync``); with ``--realtime`` free-running and
  judged from the bus.

``Program.record()`` is the trace's ``program`` metadata record (kind, what ran,
build id or sha256, how its ticks were judged).
"""
from __future__ import annotations

import importlib
import re
import shlex
import shutil
from dataclasses import dataclass
from pathlib import Path

from wheelleg.hil.program import library
from wheelleg.hil.program.library import ProgramError
from wheelleg.hil.program.process import split_command

PYTHON, FIRMWARE, LIBRARY, COMMAND = "python", "firmware", "library", "command"
FIRMWARE_BUILD = ("wheelleg.hil.firmware_build", "build")  # (module, function): function("lib") -> the library
_LIBRARY_NAME = re.compile(r"\.(so(\.\d+)*|dylib)$")


@dataclass(frozen=True)
class Program:
    """One program: ``kind`` python | library | command; ``text`` as given on the command line."""

    kind: str = PYTHON
    text: str = PYTHON
    path: Path | None = None  # a library's file
    words: tuple[str, ...] = ()  # a command's words, placeholders unfilled
    build_id: str = ""  # wl_build_id() of a library
    sha256: str = ""  # of the library file, or of a command's executable

    @property
    def in_process(self) -> bool:
        return self.kind != COMMAND

    def node_factory(self, robot):
        """``build_controller(buses, sync, period_s)`` of this program on ``robot`` (``Robot``)."""
        if self.kind == PYTHON:
            return robot.build_controller
        if self.kind == LIBRARY:
            return library.node_factory(self.path)
        raise ValueError(f"program {self.text!r} is a command: it runs as its own process, not in-process")

    def record(self, judged_by: str, argv: list[str] | None = None) -> dict[str, str]:
        """The trace's ``program`` metadata record; ``judged_by``: heartbeat | tick_log | bus;
        ``argv``: a command's words as started (placeholders filled)."""
        out = {"kind": self.kind, "program": self.text, "judged_by": judged_by}
        if self.path is not None:
            out["path"] = str(self.path)
        if self.words:
            out["command"] = shlex.join(argv or self.words)
        if self.build_id:
            out["build_id"] = self.build_id
        if self.sha256:
            out["sha256"] = self.sha256
        return out


def parse(text: str | None, robot: str | None = None) -> Program:
    """``--program TEXT`` as a ``Program``; ``ProgramError``/ValueError (one line) for a bad one.
    ``robot``: the registered robot's name (library programs speak the wheel-legged robot's ABI)."""
    text = (text or PYTHON).strip()
    if text == PYTHON:
        return Program()
    if text == FIRMWARE:
        return _library(firmware_library(), robot, text)
    if text.startswith("cmd:"):
        return _command(text[4:], text)
    if text.startswith("lib:"):
        return _library(Path(text[4:]), robot, text)
    if not any(c.isspace() for c in text) and _LIBRARY_NAME.search(text):  # one word (a path with spaces: lib:)
        return _library(Path(text), robot, text)
    return _command(text, text)


def _library(path: Path, robot: str | None, text: str) -> Program:
    if robot not in (None, "wheel-legged"):
        raise ProgramError(f"program {text!r}: a library speaks the wheel-legged robot's lockstep ABI, "
                           f"not the {robot} robot's")
    build_id = library.build_id(path)  # checks the ABI: one line if it is not one
    return Program(LIBRARY, text, path.resolve(), build_id=build_id, sha256=library.sha256_of(path))


def _command(words_text: str, text: str) -> Program:
    words = split_command(words_text)
    executable = shutil.which(words[0])
    return Program(COMMAND, text, words=tuple(words), sha256=library.sha256_of(Path(executable)))


def firmware_library() -> Path:
    """The repository's firmware library, built on demand; ``ProgramError`` while the repository has none."""
    module, function = FIRMWARE_BUILD
    try:
        build = getattr(importlib.import_module(module), function)
    except (ImportError, AttributeError):
        raise ProgramError("program 'firmware': this checkout has no firmware build yet "
                           f"({module}.{function}); give the library's path instead (--program PATH.so)") from None
    try:
        return Path(build("lib"))
    except Exception as exc:  # noqa: BLE001 - a failed build is the program's error, on one line
        raise ProgramError(f"program 'firmware': the build failed: {str(exc).splitlines()[0] if str(exc) else exc!r}") \
            from None


def describe(record: dict) -> str:
    """The trace's ``program`` record on one line (``wheelleg run``, ``wheelleg inspect``)."""
    what = record.get("command") or record.get("path") or record.get("program", "?")
    ident = f", build {record['build_id']}" if record.get("build_id") else ""
    digest = f", sha256 {record['sha256'][:16]}" if record.get("sha256") else ""
    return f"{record.get('kind', '?')} {what}{ident}{digest}; ticks judged by {record.get('judged_by', '?')}"
