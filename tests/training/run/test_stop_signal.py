"""The training's Ctrl-C / SIGTERM handler (training.run.stop_signal)."""

from __future__ import annotations

import io
import os
import signal
import sys
from typing import Any

import pytest

from training.run.stop_signal import stop_signal_handler

LINE = "\nSIGINT: stopping after a checkpoint at the next rollout boundary (again to stop now)\n"


def _state() -> dict[str, Any]:
    return {"stop_requested": False, "stopped": False}


def test_first_signal_asks_for_a_stop_the_second_stops_now_and_after_the_end_none(
    capsys: pytest.CaptureFixture[str],
) -> None:
    state = _state()
    handler = stop_signal_handler(state)
    handler(signal.SIGINT, None)
    assert state["stop_requested"] and capsys.readouterr().err == LINE
    with pytest.raises(KeyboardInterrupt):
        handler(signal.SIGTERM, None)
    state["stopped"] = True
    handler(signal.SIGINT, None)  # winding down: nothing to gain, no exception
    assert capsys.readouterr().err == ""


class _ProxyThatSignals(io.StringIO):
    """A stderr during whose first write a second Ctrl-C arrives: a real SIGINT to this process,
    handled inside the write (as CPython's buffered writer does after each write to a file;
    here at the next bytecode)."""

    def __init__(self) -> None:
        super().__init__()
        self.sent = False

    def write(self, text: str) -> int:
        if not self.sent:
            self.sent = True
            os.kill(os.getpid(), signal.SIGINT)
        for _ in range(3):  # bytecode boundaries: the pending signal's handler runs here
            pass
        return super().write(text)


def test_a_second_signal_during_the_first_ones_line_stops_after_the_whole_line(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The second Ctrl-C lands inside the write of the first one's line: it must not cut the
    line (its newline once went missing, and the next line joined it); the stop still happens,
    right after the line."""
    state = _state()
    handler = stop_signal_handler(state)
    proxy = _ProxyThatSignals()
    monkeypatch.setattr(sys, "stderr", proxy)
    previous = signal.signal(signal.SIGINT, handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGINT)
            for _ in range(3):  # let the first signal's handler run
                pass
    finally:
        signal.signal(signal.SIGINT, previous)
    assert proxy.sent and proxy.getvalue() == LINE
    assert state["stop_requested"] and not state.get("announcing") and "stop_now" not in state
