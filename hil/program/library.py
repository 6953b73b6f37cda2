"""A program as a shared library with the lockstep C ABI, run in-process in virtual time.

The ABI (version 2, header ``firmware/include/wl_lockstep.h``): ``wl_abi_version``,
``wl_build_id``, ``wl_init(period_us)``, ``wl_step(now_us, rx, rx_time_us, n_rx, tx,
max_tx)``, ``wl_status``, ``wl_debug_names``, ``wl_debug``, ``wl_shutdown``; frames are
16-byte ``wl_frame_t`` (id, bus 0 = CAN1 / 1 = CAN2, extended, dlc, pad, data[8]).

``LibraryController`` is such a library as the program without I/O that
``wheelleg.controller.can_node.CanNode`` drives (``on_frame``, ``tick``,
``shutdown_frames``): the frames the program's buses receive are collected, SYNC
excepted (the program knows nothing of it); each tick hands them to ``wl_step``
with the tick's time, sends what it returns and then the rig's heartbeat, every field
of it from ``wl_status`` (the program's own: mode, warning level, offline count and
mask, motors enabled, off ground, fallen, fault latched, bad frames). So the rig, replay
and the differential check drive a library exactly as they drive the Python program.

Each controller loads its own copy of the file (``dlopen`` of one path twice gives
the same globals: two programs of one file, as in a differential check, would share
their state).
"""
from __future__ import annotations

import ctypes
import hashlib
import shutil
import struct
import tempfile
import time
from pathlib import Path

import can

from wheelleg.controller import messages
from wheelleg.controller.modes import Mode
from wheelleg.controller.node import TickResult
from wheelleg.controller.can_node import CanNode
from wheelleg.controller.telemetry import DEBUG_FIELDS
from wheelleg.dbc import CAN1, CAN2, load_file
from wheelleg.dbc.codec import MessageCodec
from wheelleg.hil.record.schemas import described_schema

ABI_VERSION = 2  # 1 had Mode and OfflineMask only in wl_status: refused
SYMBOLS = ("wl_abi_version", "wl_build_id", "wl_init", "wl_step", "wl_status", "wl_debug_names", "wl_debug",
           "wl_shutdown")
MAX_RX = 512  # frames one period may bring (2 ms at 1 Mbit/s on two buses: < 40); more are dropped, counted
MAX_TX = 64  # frames one wl_step may return (the Python program sends at most 13 a tick)
MAX_DEBUG = 256  # debug values read a tick
BUS_INDEX = {CAN1: 0, CAN2: 1}
ROLE_OF_BUS = {0: CAN1, 1: CAN2}
_SYNC = load_file("rig.dbc").get_message_by_name("SYNC")
_SYNC_ID, _SYNC_LENGTH = _SYNC.frame_id, _SYNC.length
_SYNC_CODEC = MessageCodec.of(_SYNC)  # compiled: cantools' decode costs ~10 us a frame
_FRAME = struct.Struct("<IBBBB8s")  # wl_frame_t, packed and read in place: ctypes field by field costs ~5x more
_TIME = struct.Struct("<Q")


class ProgramError(ValueError):
    """A program that cannot be run (one line: what is wrong and with which file or command)."""


class WlFrame(ctypes.Structure):
    _fields_ = [("id", ctypes.c_uint32), ("bus", ctypes.c_uint8), ("extended", ctypes.c_uint8),
                ("dlc", ctypes.c_uint8), ("pad", ctypes.c_uint8), ("data", ctypes.c_uint8 * 8)]


class WlStatus(ctypes.Structure):
    """``wl_status_t``: the heartbeat's fields as the program set them (rig.dbc Heartbeat)."""

    _fields_ = [("mode", ctypes.c_uint8), ("warning_level", ctypes.c_uint8), ("offline_count", ctypes.c_uint8),
                ("offline_mask", ctypes.c_uint8), ("motors_enabled", ctypes.c_uint8), ("off_ground", ctypes.c_uint8),
                ("fallen", ctypes.c_uint8), ("fault_latched", ctypes.c_uint8), ("bad_frames", ctypes.c_uint32),
                ("ticks", ctypes.c_uint32)]


assert ctypes.sizeof(WlFrame) == 16 and ctypes.sizeof(WlStatus) == 16  # the ABI's layouts


def sha256_of(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def open_library(path: Path) -> ctypes.CDLL:
    """``path`` loaded with its ABI's signatures; ``ProgramError`` (one line) when it is not a
    shared library, lacks a function of the ABI or speaks another ABI version."""
    path = Path(path)
    if not path.is_file():
        raise ProgramError(f"program library {path}: no such file")
    try:
        lib = ctypes.CDLL(str(path.resolve()))
    except OSError as exc:
        raise ProgramError(f"program library {path}: cannot be loaded ({str(exc).splitlines()[0]})") from None
    missing = [name for name in SYMBOLS if not hasattr(lib, name)]
    if missing:
        raise ProgramError(f"program library {path}: not the lockstep ABI (no {', '.join(missing)}; "
                           f"see docs/design.md, programs)")
    _declare(lib)
    version = lib.wl_abi_version()
    if version != ABI_VERSION:
        raise ProgramError(f"program library {path}: lockstep ABI version {version}, the rig speaks {ABI_VERSION} "
                           "(rebuild it against firmware/include/wl_lockstep.h)")
    return lib


def _declare(lib: ctypes.CDLL) -> None:
    frames = ctypes.POINTER(WlFrame)
    lib.wl_abi_version.restype = ctypes.c_int32
    lib.wl_abi_version.argtypes = []
    lib.wl_build_id.restype = ctypes.c_char_p
    lib.wl_build_id.argtypes = []
    lib.wl_init.restype = None
    lib.wl_init.argtypes = [ctypes.c_uint32]
    lib.wl_step.restype = ctypes.c_int32
    lib.wl_step.argtypes = [ctypes.c_uint64, frames, ctypes.POINTER(ctypes.c_uint64), ctypes.c_int32, frames,
                            ctypes.c_int32]
    lib.wl_status.restype = None
    lib.wl_status.argtypes = [ctypes.POINTER(WlStatus)]
    lib.wl_debug_names.restype = ctypes.c_char_p
    lib.wl_debug_names.argtypes = []
    lib.wl_debug.restype = ctypes.c_int32
    lib.wl_debug.argtypes = [ctypes.POINTER(ctypes.c_float), ctypes.c_int32]
    lib.wl_shutdown.restype = ctypes.c_int32
    lib.wl_shutdown.argtypes = [frames, ctypes.c_int32]


def build_id(path: Path) -> str:
    """The library's ``wl_build_id()`` (checked: ``open_library``)."""
    raw = open_library(path).wl_build_id()
    return raw.decode("utf-8", "replace") if raw else ""


class _Copy:
    """A private copy of the library file, loaded: its own globals (module docstring)."""

    def __init__(self, path: Path):
        self.dir = tempfile.TemporaryDirectory(prefix="wheelleg-program-")
        copy = Path(self.dir.name) / Path(path).name
        shutil.copyfile(path, copy)
        self.lib = open_library(copy)


class LibraryController:
    """A lockstep-ABI library as a controller without I/O (see the module docstring)."""

    def __init__(self, path: Path, period_s: float, record_debug: bool = True):
        self.path = Path(path)
        self._copy = _Copy(self.path)
        self.lib = lib = self._copy.lib
        self.period_s = period_s
        self.record_debug = record_debug
        lib.wl_init(round(period_s * 1e6))
        self._rx_buf, self._rx_t_buf = bytearray(_FRAME.size * MAX_RX), bytearray(_TIME.size * MAX_RX)
        self._rx = (WlFrame * MAX_RX).from_buffer(self._rx_buf)
        self._rx_t = (ctypes.c_uint64 * MAX_RX).from_buffer(self._rx_t_buf)
        self._n_rx = 0
        self._tx_buf = bytearray(_FRAME.size * MAX_TX)
        self._tx = (WlFrame * MAX_TX).from_buffer(self._tx_buf)
        self._status = WlStatus()
        self._debug = (ctypes.c_float * MAX_DEBUG)()
        names = (lib.wl_debug_names() or b"").decode("utf-8", "replace")
        self.debug_names = tuple(n.strip() for n in names.split(",") if n.strip())[:MAX_DEBUG]
        self.debug_schema = described_schema("wheelleg.ProgramDebug", {
            n: DEBUG_FIELDS.get(n, "the program's own debug signal (its unit: the program's documentation)")
            for n in self.debug_names})
        self.step_times: list[float] | None = None  # when a list: wall s of each wl_step (tools.program_speed)
        self.dropped_rx = 0  # frames past MAX_RX in one period
        self.bad_counts = 0  # wl_step returned a count outside 0..MAX_TX

    # -- what CanNode calls ---------------------------------------------------------------------
    def on_frame(self, msg: can.Message, bus: str, now_s: float) -> int | None:
        """Keep a received frame for the next ``wl_step``; a SYNC is the rig's: its tick, not kept."""
        if msg.is_error_frame or msg.is_remote_frame or msg.is_fd:
            return None
        ident, extended = msg.arbitration_id, msg.is_extended_id
        if ident == _SYNC_ID and not extended:
            return int(_SYNC_CODEC.decode_raw(bytes(msg.data))["Tick"]) if msg.dlc == _SYNC_LENGTH else None
        n = self._n_rx
        if n >= MAX_RX:
            self.dropped_rx += 1
            return None
        dlc = msg.dlc if msg.dlc <= 8 else 8
        _FRAME.pack_into(self._rx_buf, n * _FRAME.size, ident, BUS_INDEX[bus], extended, dlc, 0, bytes(msg.data[:dlc]))
        _TIME.pack_into(self._rx_t_buf, n * _TIME.size, max(0, round(now_s * 1e6)))
        self._n_rx = n + 1
        return None

    def tick(self, tick: int, now_s: float) -> TickResult:
        if self.step_times is None:
            n = self.lib.wl_step(max(0, round(now_s * 1e6)), self._rx, self._rx_t, self._n_rx, self._tx, MAX_TX)
        else:
            t0 = time.perf_counter()
            n = self.lib.wl_step(max(0, round(now_s * 1e6)), self._rx, self._rx_t, self._n_rx, self._tx, MAX_TX)
            self.step_times.append(time.perf_counter() - t0)
        self._n_rx = 0
        result = TickResult()
        for msg, role in self._frames(n, now_s):
            result.frames[role].append(msg)
        status = self._status
        self.lib.wl_status(ctypes.byref(status))
        mode = status.mode
        result.mode = Mode(mode) if mode in Mode._value2member_map_ else mode
        hb = messages.heartbeat(tick, mode, status.warning_level, status.offline_mask, status.offline_count,
                                motors_enabled=bool(status.motors_enabled), off_ground=bool(status.off_ground),
                                fallen=bool(status.fallen), fault_latched=bool(status.fault_latched),
                                bad_frames=status.bad_frames, t_s=now_s)
        result.frames[CAN1].append(hb)
        result.frames[CAN2].append(hb)
        if self.record_debug and self.debug_names:
            count = max(0, min(self.lib.wl_debug(self._debug, len(self.debug_names)), len(self.debug_names)))
            result.debug = dict(zip(self.debug_names, self._debug[:count]))  # a slice: Python floats at once
        return result

    def shutdown_frames(self, now_s: float) -> dict:
        n = self.lib.wl_shutdown(self._tx, MAX_TX)
        out = {CAN1: [], CAN2: []}
        for msg, role in self._frames(n, now_s):
            out[role].append(msg)
        return out

    def _frames(self, n: int, now_s: float):
        """(python-can message, bus role) of ``tx[0..n)``; a count outside 0..MAX_TX is counted and clamped,
        a frame on a bus other than 0 or 1 is dropped."""
        if not 0 <= n <= MAX_TX:
            self.bad_counts += 1
            n = max(0, min(n, MAX_TX))
        for i in range(n):
            ident, bus, extended, dlc, _, data = _FRAME.unpack_from(self._tx_buf, i * _FRAME.size)
            role = ROLE_OF_BUS.get(bus)
            if role is None:
                continue
            dlc = dlc if dlc <= 8 else 8
            yield can.Message(now_s, ident, bool(extended), False, False, None, dlc, data[:dlc]), role


def node_factory(path: Path):
    """``build_controller(buses, sync, period_s)`` (``wheelleg.hil.robots.Robot``) for the library at ``path``."""

    def build(buses: dict, sync: bool, period_s: float) -> CanNode:
        return CanNode(buses[CAN1], buses[CAN2], LibraryController(path, period_s), sync=sync, period_s=period_s)

    return build
