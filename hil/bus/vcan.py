"""Virtual SocketCAN channels (vcan0 = CAN1, vcan1 = CAN2) for the real-SocketCAN path.

``up()`` / ``down()`` create and remove the vcan links with ``ip link``;
``available()`` tells tests whether both channels exist and open as python-can
``socketcan`` buses.  Where the kernel cannot make vcan links (built without
CAN, a container, no CAP_NET_ADMIN), ``VcanError`` carries ``ip``'s own error
and the way to run the socketcan tests anyway: inside user-mode-linux with
``wheelleg vcan uml -- CMD`` (``UML_RUNNER``, shipped in the package).
"""
from __future__ import annotations

import shutil
import subprocess

from pathlib import Path

import can

CHANNELS = ("vcan0", "vcan1")
TXQUEUELEN = 1000  # frames; the default 10 drops bursts with ENOBUFS on real CAN links
SYS_NET = Path("/sys/class/net")
UML_HINT = (
    "To run the socketcan tests anyway, boot user-mode-linux with real vcan0/vcan1:\n"
    "    apt-get install user-mode-linux kmod iproute2 can-utils\n"
    "    wheelleg vcan uml -- python3 -m pytest -q -m socketcan"
)
# the user-mode-linux runner (a bash script, with the guest's init and a C shim beside it)
UML_RUNNER = Path(__file__).resolve().parent / "uml" / "uml-vcan.sh"

class VcanError(RuntimeError):
    """The kernel (or our rights) cannot give vcan links; the message says why and what to do."""

def _ip(*args: str) -> subprocess.CompletedProcess:
    ip = shutil.which("ip")
    if ip is None:
        raise VcanError("'ip' not found (apt-get install iproute2).\n" + UML_HINT)
    return subprocess.run([ip, *args], capture_output=True, text=True, check=False)

def exists(channel: str) -> bool:
    """True if the kernel has a network interface named ``channel``."""
    return (SYS_NET / channel).exists()

def txqueuelen(channel: str) -> int:
    """The interface's transmit queue length in frames (sysfs ``tx_queue_len``)."""
    return int((SYS_NET / channel / "tx_queue_len").read_text())

def _try_modprobe() -> str:
    """Load the vcan module if modprobe exists; returns its error text ('' on success)."""
    modprobe = shutil.which("modprobe")
    if modprobe is None:
        return "modprobe not found"
    done = subprocess.run([modprobe, "vcan"], capture_output=True, text=True, check=False)
    return "" if done.returncode == 0 else (done.stderr.strip() or f"exit status {done.returncode}")

def _add(channel: str) -> None:
    """``ip link add dev <channel> type vcan``, retried once after ``modprobe vcan``."""
    first = _ip("link", "add", "dev", channel, "type", "vcan")
    if first.returncode == 0:
        return
    if _try_modprobe() == "":
        retry = _ip("link", "add", "dev", channel, "type", "vcan")
        if retry.returncode == 0:
            return
    raise VcanError(_explain(channel, first.stderr.strip()))

def _explain(channel: str, ip_error: str) -> str:
    why = "this kernel has no vcan support (built without CAN, or a container without the module)"
    if "not permitted" in ip_error.lower() or "permission" in ip_error.lower():
        why = "creating network links needs root or CAP_NET_ADMIN (try sudo), or this is a container"
    return (f"cannot create {channel}: `ip link add dev {channel} type vcan` failed: {ip_error}\n"
            f"Likely cause: {why}.\n{UML_HINT}")

def up(channels: tuple[str, ...] = CHANNELS, txqueuelen_frames: int = TXQUEUELEN) -> list[str]:
    """Create (if absent) each vcan link, set its txqueuelen and bring it up.

    Returns one line per channel saying what was done. Raises ``VcanError``.
    """
    report = []
    for channel in channels:
        created = not exists(channel)
        if created:
            _add(channel)
        done = _ip("link", "set", channel, "txqueuelen", str(txqueuelen_frames), "up")
        if done.returncode != 0:
            raise VcanError(f"`ip link set {channel} txqueuelen {txqueuelen_frames} up` failed: "
                            f"{done.stderr.strip()}\n{UML_HINT}")
        verb = "created" if created else "already there,"
        report.append(f"{channel}: {verb} up, txqueuelen {txqueuelen(channel)}")
    return report

def down(channels: tuple[str, ...] = CHANNELS) -> list[str]:
    """Delete each link that exists. Returns one line per channel. Raises ``VcanError``."""
    report = []
    for channel in channels:
        if not exists(channel):
            report.append(f"{channel}: not present")
            continue
        done = _ip("link", "delete", "dev", channel)
        if done.returncode != 0:
            raise VcanError(f"`ip link delete dev {channel}` failed: {done.stderr.strip()}")
        report.append(f"{channel}: deleted")
    return report

def unavailable_reason(channels: tuple[str, ...] = CHANNELS) -> str | None:
    """Why the socketcan tests cannot run here, or None if every channel opens."""
    for channel in channels:
        if not exists(channel):
            return f"{channel} does not exist (run `wheelleg vcan up`).\n{UML_HINT}"
        try:
            can.Bus(interface="socketcan", channel=channel).shutdown()
        except (OSError, can.CanError) as exc:
            return f"{channel} exists but python-can cannot open it: {exc}\n{UML_HINT}"
    return None

def available(channels: tuple[str, ...] = CHANNELS) -> bool:
    """True if every channel exists and python-can opens a socketcan bus on it."""
    return unavailable_reason(channels) is None
