"""Pool workers leave Ctrl-C to their parent (no worker tracebacks on an interrupt)."""

from __future__ import annotations


def test_pool_workers_leave_ctrl_c_to_their_parent():
    """Workers started with ignore_interrupts ignore SIGINT, so Ctrl-C prints no worker
    tracebacks; the parent keeps its handler."""
    import multiprocessing
    import signal
    from concurrent.futures import ProcessPoolExecutor

    from simplexspline._workers import ignore_interrupts, interrupt_handler

    # a shell's background job starts with SIGINT ignored, and children inherit that: give
    # the parent Python's own handler for the test, so the workers' SIG_IGN is their doing
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"),
                                 initializer=ignore_interrupts) as pool:
            assert pool.submit(interrupt_handler).result(timeout=120) == signal.SIG_IGN
        assert interrupt_handler() is signal.default_int_handler
    finally:
        if before is not None:       # None: installed outside Python, cannot be restored
            signal.signal(signal.SIGINT, before)
