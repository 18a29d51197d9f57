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


def _worker_state() -> tuple:
    """Run in a worker: which of the preloaded modules it has, and its SIGINT handler."""
    import signal
    import sys

    from simplexspline._workers import PRELOAD

    return [m for m in PRELOAD if m in sys.modules], signal.getsignal(signal.SIGINT)


def test_the_package_pools_fork_workers_from_a_preloaded_server():
    """process_context: a fork server that imported the worker modules once (a worker
    starts with them loaded: no 1.5 s of imports each), spawn where there is none; its
    workers still ignore SIGINT (the initializer) and run the package's functions."""
    import multiprocessing
    import signal
    from concurrent.futures import ProcessPoolExecutor

    from simplexspline._workers import PRELOAD, ignore_interrupts, process_context

    ctx = process_context()
    if "forkserver" in multiprocessing.get_all_start_methods():
        assert ctx.get_start_method() == "forkserver"
    else:  # pragma: no cover - Windows
        assert ctx.get_start_method() == "spawn"
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with ProcessPoolExecutor(2, mp_context=ctx, initializer=ignore_interrupts) as pool:
            results = [f.result(timeout=120) for f in
                       [pool.submit(_worker_state) for _ in range(2)]]
    finally:
        if before is not None:
            signal.signal(signal.SIGINT, before)
    for loaded, handler in results:
        assert handler == signal.SIG_IGN
        if ctx.get_start_method() == "forkserver":
            # the server imported them (the sim module needs jsbsim: skipped without it)
            assert set(loaded) >= set(PRELOAD[:2])
