"""The handler of Ctrl-C / SIGTERM during training: the first signal asks for a stop at the next
rollout boundary (after a checkpoint), the second stops at once (``KeyboardInterrupt``)."""

from __future__ import annotations

import signal
import sys
from collections.abc import Callable
from typing import Any


def stop_signal_handler(state: dict[str, Any]) -> Callable[[int, Any], None]:
    """A signal handler that keeps its decisions in ``state`` (the training's state dict):

    * ``state["stopped"]`` true (training is past its last checkpoint, winding down): nothing;
    * the first signal: ``state["stop_requested"] = True`` and one line on stderr saying so;
    * a later one: ``KeyboardInterrupt``, the immediate stop.

    A second signal that arrives while the first one's line is being written is handled inside
    that write (CPython's buffered writer runs pending signal handlers after each write to the
    file). Raising there would cut the line before its newline (the next line then joined it);
    instead it only marks the stop, and the first handler raises once its line is out.
    """

    def on_signal(signum: int, frame: Any) -> None:
        if state["stopped"]:
            return
        if state["stop_requested"]:
            if state.get("announcing"):
                state["stop_now"] = True
                return
            raise KeyboardInterrupt
        state["announcing"] = True
        state["stop_requested"] = True
        try:
            print(
                f"\n{signal.Signals(signum).name}: stopping after a checkpoint at the next "
                f"rollout boundary (again to stop now)",
                file=sys.stderr,
                flush=True,
            )
        finally:
            state["announcing"] = False
        if state.pop("stop_now", False):
            raise KeyboardInterrupt

    return on_signal
