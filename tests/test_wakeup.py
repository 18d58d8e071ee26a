"""The loop's wake-ups: `notify()` wakes `wait()` and counts as news, `reschedule()` wakes it
without news, many wake-ups before a wait are one, and both are safe from a signal handler and
after `close()`."""

from __future__ import annotations

import os
import signal
import threading

import pytest

from gazed.wakeup import Wakeup


def test_wait_times_out_without_news() -> None:
    with Wakeup() as wakeup:
        assert wakeup.wait(0.0) is False
        assert wakeup.wait(0.05) is False
        assert wakeup.wakeups == 0


def test_notify_wakes_and_counts_reschedule_wakes_only() -> None:
    with Wakeup() as wakeup:
        wakeup.notify()
        assert wakeup.wait(5.0) is True and wakeup.wakeups == 1
        wakeup.reschedule()
        assert wakeup.wait(5.0) is True and wakeup.wakeups == 1
        assert wakeup.wait(0.0) is False  # each wake-up is consumed by one wait


def test_wake_ups_before_a_wait_are_one_and_never_block() -> None:
    with Wakeup() as wakeup:
        for _ in range(200_000):  # far more than the pipe holds
            wakeup.notify()
        assert wakeup.wakeups == 200_000
        assert wakeup.wait(5.0) is True
        assert wakeup.wait(0.0) is False


def test_another_thread_wakes_the_waiter() -> None:
    with Wakeup() as wakeup:
        timer = threading.Timer(0.05, wakeup.notify)
        timer.start()
        assert wakeup.wait(10.0) is True
        timer.join()


def test_a_signal_handler_wakes_the_waiter() -> None:
    with Wakeup() as wakeup:
        previous = signal.signal(signal.SIGUSR1, lambda *_: wakeup.notify())
        try:
            os.kill(os.getpid(), signal.SIGUSR1)
            assert wakeup.wait(10.0) is True and wakeup.wakeups == 1
        finally:
            signal.signal(signal.SIGUSR1, previous)


def test_after_close_wake_ups_are_ignored_and_wait_refuses() -> None:
    wakeup = Wakeup()
    wakeup.close()
    wakeup.notify()
    wakeup.reschedule()
    with pytest.raises(ValueError, match="closed"):
        wakeup.wait(0.0)
    wakeup.close()  # twice is fine
