"""Pool workers leave Ctrl-C to their parent (no worker tracebacks on an interrupt)."""

from __future__ import annotations


def test_pool_workers_leave_ctrl_c_to_their_parent():
    """Workers started with ignore_interrupts ignore SIGINT, so Ctrl-C prints no worker
    tracebacks; the parent keeps its handler."""
    import multiprocessing
    import signal
    from concurrent.futures import ProcessPoolExecutor

    from simplexspline._workers import ignore_interrupts, interrupt_handler

    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"),
                             initializer=ignore_interrupts) as pool:
        assert pool.submit(interrupt_handler).result(timeout=120) == signal.SIG_IGN
    assert interrupt_handler() is not signal.SIG_IGN
