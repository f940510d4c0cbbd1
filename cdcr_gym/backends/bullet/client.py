"""pybullet client handling: the silent import, connecting (DIRECT or GUI), disconnecting, and
why a connected backend cannot be copied.

pybullet prints banners from C (``pybullet build time`` at import, GL and thread information at
connect) straight to the process's file descriptors, bypassing ``sys.stdout``; it is imported
and connected with those descriptors pointed at /dev/null. Its GUI needs an X11/Wayland display
and, without one, ends the whole interpreter with exit code 1 and no message: :func:`connect`
checks for a display first and raises instead.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
import weakref
from collections.abc import Iterator
from types import ModuleType
from typing import Any

from cdcr_gym.rendering import has_display

__all__ = ["Connection", "pybullet", "silenced_stdio", "copy_refused"]

_LIBC: ctypes.CDLL | None | bool = False
_PYBULLET: ModuleType | None = None


def _libc() -> ctypes.CDLL | None:
    global _LIBC
    if _LIBC is False:
        try:
            _LIBC = ctypes.CDLL(None)
        except OSError:  # pragma: no cover
            _LIBC = None
    return _LIBC  # type: ignore[return-value]


@contextlib.contextmanager
def silenced_stdio() -> Iterator[None]:
    """Redirect the C-level file descriptors 1 and 2 to /dev/null for the duration.

    Flushes Python's and C's buffers, points fds 1 and 2 at /dev/null, and restores them
    afterwards. Output written by other threads in that short window is lost as well.
    """
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    libc = _libc()
    if libc is not None:
        libc.fflush(None)
    saved = []
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
    except OSError:  # pragma: no cover - no /dev/null: just run unsilenced
        yield
        return
    try:
        for fd in (1, 2):
            try:
                saved.append((fd, os.dup(fd)))
                os.dup2(devnull, fd)
            except OSError:  # pragma: no cover - fd not open
                pass
        yield
    finally:
        if libc is not None:
            libc.fflush(None)
        for fd, copy in saved:
            os.dup2(copy, fd)
            os.close(copy)
        os.close(devnull)


def pybullet() -> ModuleType:
    """The pybullet module, imported once and silently."""
    global _PYBULLET
    if _PYBULLET is None:
        if "pybullet" in sys.modules:
            import pybullet as module
        else:
            with silenced_stdio():
                import pybullet as module
        _PYBULLET = module
    return _PYBULLET


def _disconnect(client: int) -> None:
    """Disconnect a pybullet client if it is still connected (finalizer; never raises)."""
    pb = _PYBULLET
    if pb is None:  # pragma: no cover
        return
    with contextlib.suppress(Exception):
        if pb.getConnectionInfo(physicsClientId=client)["isConnected"]:
            pb.disconnect(physicsClientId=client)


class Connection:
    """One pybullet physics client, disconnected by :meth:`close` or when ``owner`` is collected.

    Args:
        owner: the object whose lifetime bounds the client's (a finalizer disconnects it).
        gui: open pybullet's GUI window instead of a headless (DIRECT) client.

    Raises:
        RuntimeError: ``gui=True`` without a display (instead of pybullet's silent exit), or
            pybullet refusing the connection (it allows one GUI client per process).
    """

    def __init__(self, owner: Any, gui: bool) -> None:
        if gui and not has_display():
            raise RuntimeError(
                "gui=True (render_mode='human') needs a display, and neither DISPLAY nor "
                "WAYLAND_DISPLAY is set (pybullet would end the interpreter without a message); "
                "use gui=False and render_mode='rgb_array' on a headless machine"
            )
        self.pb = pb = pybullet()
        with silenced_stdio():
            self.id: int = pb.connect(pb.GUI if gui else pb.DIRECT)
        if self.id < 0:
            raise RuntimeError("pybullet could not connect (a GUI may already be open)")
        self._finalizer = weakref.finalize(owner, _disconnect, self.id)

    def close(self) -> None:
        """Disconnect (safe to call more than once)."""
        self._finalizer()


def copy_refused(name: str) -> TypeError:
    """The error for pickling, deep-copying or cloudpickling an object that holds a client.

    A copy would share the pybullet client (stepping the copy would move the original), and
    rebuilding the client would not restore the dynamic state bit for bit; envs are copied by
    building a new one from their arguments (what SubprocVecEnv and AsyncVectorEnv do with env
    factories).
    """
    return TypeError(
        f"a {name} (and an env holding one) cannot be pickled or copied: its state is a "
        "pybullet client the copy would share; make a new env with gymnasium.make(...) "
        "(SubprocVecEnv/AsyncVectorEnv take env factories and work)"
    )
