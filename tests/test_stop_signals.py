"""aamsim.stop_signals: the stop signals handled inside a block, the handlers before it put back after it."""

from __future__ import annotations

import os
import signal
import threading

import pytest

from aamsim.stop_signals import STOP_SIGNALS, StopSignals


def test_both_stop_signals_reach_the_handler_inside_the_block_and_the_old_handlers_come_back():
    heard: list[str] = []
    before = {s: signal.getsignal(s) for s in STOP_SIGNALS}
    with StopSignals(lambda num, frame: heard.append(signal.Signals(num).name)) as stop:
        assert stop.installed
        os.kill(os.getpid(), signal.SIGTERM)
        os.kill(os.getpid(), signal.SIGINT)
    assert heard == ["SIGTERM", "SIGINT"]
    assert {s: signal.getsignal(s) for s in STOP_SIGNALS} == before
    assert not stop.installed


def test_replace_changes_the_handler_for_the_rest_of_the_block_only():
    heard: list[str] = []
    before = signal.getsignal(signal.SIGTERM)
    with StopSignals(lambda num, frame: heard.append("first")) as stop:
        stop.replace(lambda num, frame: heard.append("second"))
        os.kill(os.getpid(), signal.SIGTERM)
    assert heard == ["second"]
    assert signal.getsignal(signal.SIGTERM) is before


def test_default_int_handler_turns_an_ignored_sigint_into_keyboard_interrupt():
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)  # as a background job of a script starts
    try:
        with pytest.raises(KeyboardInterrupt), StopSignals(signal.default_int_handler):
            os.kill(os.getpid(), signal.SIGINT)
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, previous)


def test_outside_the_main_thread_nothing_is_installed_and_nothing_fails():
    seen: dict[str, object] = {}

    def worker() -> None:
        with StopSignals(lambda num, frame: None) as stop:
            seen["installed"] = stop.installed
            stop.replace(lambda num, frame: None)
        seen["done"] = True

    before = signal.getsignal(signal.SIGTERM)
    t = threading.Thread(target=worker)
    t.start()
    t.join()
    assert seen == {"installed": False, "done": True}
    assert signal.getsignal(signal.SIGTERM) is before
