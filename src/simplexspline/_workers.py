"""Worker processes that leave Ctrl-C to their parent.

A terminal's Ctrl-C reaches every process of its group: without this, each worker of a
process pool prints its own KeyboardInterrupt traceback. Pools are started with
:func:`ignore_interrupts` as initializer; the parent alone turns the interrupt into the
command line's one-line "interrupted" message (exit code 130).
"""

from __future__ import annotations

import signal

__all__ = ["ignore_interrupts", "interrupt_handler"]


def ignore_interrupts() -> None:
    """Pool initializer: this worker ignores SIGINT (its parent handles Ctrl-C)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def interrupt_handler() -> object:
    """The SIGINT handler of this process (for tests and diagnostics)."""
    return signal.getsignal(signal.SIGINT)
