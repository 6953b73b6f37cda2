"""A virtual screen for the viewer's tests: Xvfb, its windows by name, and closing one as a user would.

Closing: the window manager's part when the user clicks a window's close box,
a WM_DELETE_WINDOW client message to the window (Xlib through ctypes; no
window manager runs on Xvfb).
"""
from __future__ import annotations

import ctypes
import ctypes.util
import os
import shutil
import subprocess
from contextlib import contextmanager

_ulong = ctypes.c_ulong


class _ClientMessage(ctypes.Structure):
    _fields_ = [("type", ctypes.c_int), ("serial", _ulong), ("send_event", ctypes.c_int),
                ("display", ctypes.c_void_p), ("window", _ulong), ("message_type", _ulong),
                ("format", ctypes.c_int), ("data", ctypes.c_long * 5)]


class _Event(ctypes.Union):
    _fields_ = [("client", _ClientMessage), ("pad", ctypes.c_long * 24)]


_CLIENT_MESSAGE = 33


def available() -> str | None:
    """Why the viewer cannot be tested here, or None."""
    if shutil.which("Xvfb") is None:
        return "no Xvfb: apt-get install xvfb (.ci/run does)"
    if ctypes.util.find_library("X11") is None:
        return "no libX11"
    return None


@contextmanager
def xvfb(width: int = 800, height: int = 600):
    """A fresh Xvfb display; yields its name (':N')."""
    read, write = os.pipe()
    server = subprocess.Popen(["Xvfb", "-displayfd", str(write), "-screen", "0", f"{width}x{height}x24",
                               "-nolisten", "tcp"], pass_fds=(write,), stderr=subprocess.DEVNULL)
    os.close(write)
    try:
        with os.fdopen(read) as pipe:
            number = pipe.readline().strip()
        yield f":{number}"
    finally:
        server.terminate()
        server.wait(timeout=10)


class Display:
    """An Xlib connection to ``name``: its top-level windows' names, and closing one."""

    def __init__(self, name: str):
        self.x = ctypes.cdll.LoadLibrary(ctypes.util.find_library("X11"))
        self.x.XOpenDisplay.restype = ctypes.c_void_p
        self.x.XDefaultRootWindow.restype = _ulong
        self.x.XDefaultRootWindow.argtypes = [ctypes.c_void_p]
        self.x.XInternAtom.restype = _ulong
        self.x.XInternAtom.argtypes = [ctypes.c_void_p, ctypes.c_char_p, ctypes.c_int]
        self.x.XQueryTree.argtypes = [ctypes.c_void_p, _ulong, ctypes.POINTER(_ulong), ctypes.POINTER(_ulong),
                                      ctypes.POINTER(ctypes.POINTER(_ulong)), ctypes.POINTER(ctypes.c_uint)]
        self.x.XFetchName.argtypes = [ctypes.c_void_p, _ulong, ctypes.POINTER(ctypes.c_char_p)]
        self.x.XSendEvent.argtypes = [ctypes.c_void_p, _ulong, ctypes.c_int, ctypes.c_long, ctypes.POINTER(_Event)]
        self.x.XFlush.argtypes = self.x.XCloseDisplay.argtypes = [ctypes.c_void_p]
        self.dpy = self.x.XOpenDisplay(name.encode())
        if not self.dpy:
            raise OSError(f"cannot open X display {name}")

    def windows(self) -> dict[str, int]:
        """Top-level window name -> id (unnamed ones left out)."""
        root, parent, count = _ulong(), _ulong(), ctypes.c_uint()
        children = ctypes.POINTER(_ulong)()
        self.x.XQueryTree(self.dpy, self.x.XDefaultRootWindow(self.dpy), ctypes.byref(root), ctypes.byref(parent),
                          ctypes.byref(children), ctypes.byref(count))
        out = {}
        for i in range(count.value):
            name = ctypes.c_char_p()
            if self.x.XFetchName(self.dpy, children[i], ctypes.byref(name)) and name.value:
                out[name.value.decode(errors="replace")] = children[i]
        return out

    def close_window(self, window: int) -> None:
        """Send ``window`` WM_DELETE_WINDOW, as a window manager does for its close box."""
        event = _Event()
        event.client.type = _CLIENT_MESSAGE
        event.client.window = window
        event.client.message_type = self.x.XInternAtom(self.dpy, b"WM_PROTOCOLS", 0)
        event.client.format = 32
        event.client.data[0] = self.x.XInternAtom(self.dpy, b"WM_DELETE_WINDOW", 0)
        self.x.XSendEvent(self.dpy, window, 0, 0, ctypes.byref(event))
        self.x.XFlush(self.dpy)

    def close(self) -> None:
        self.x.XCloseDisplay(self.dpy)
