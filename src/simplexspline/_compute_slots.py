"""Compute slots: more worker processes than cores, at most as many computing at once as
there are slots.

Why: the six coefficients' structure searches of ``identify`` take from 3 to 45 s each, and
which one is long is not known in advance. With one process per core a long search that
starts last ran alone at the end while the other core idled (the main job's F-16 CX: 41 s
started after 28 s, an identification of 69 s for 101 s of work on 2 cores). With one
process per coefficient that takes a slot for each trial fit, the searches share the cores
trial by trial and the long one runs from the start; the results do not change (each
search is deterministic). Without slots (:func:`compute_slot` outside such a pool) nothing
waits.
"""

from __future__ import annotations

import contextlib
import time

from simplexspline._workers import ignore_interrupts

__all__ = ["init_worker", "compute_slot", "busy_seconds"]

_GATE = None
_DEPTH = 0
_BUSY = 0.0
_SINCE = 0.0


def init_worker(gate) -> None:
    """Pool initializer: this worker ignores SIGINT and computes in ``gate``'s slots (a
    ``multiprocessing`` semaphore of the pool's context, or None for no limit)."""
    global _GATE
    ignore_interrupts()
    _GATE = gate


@contextlib.contextmanager
def compute_slot():
    """Hold one compute slot for the block (re-entrant; a no-op without slots)."""
    global _DEPTH, _BUSY, _SINCE
    if _GATE is None or _DEPTH:
        _DEPTH += 1
        try:
            yield
        finally:
            _DEPTH -= 1
        return
    _GATE.acquire()
    _SINCE = time.perf_counter()
    _DEPTH += 1
    try:
        yield
    finally:
        _DEPTH -= 1
        _BUSY += time.perf_counter() - _SINCE
        _GATE.release()


def busy_seconds() -> float | None:
    """Seconds this process has held a slot, the current hold included (None when it has
    no slots: then wall time is its compute time)."""
    if _GATE is None:
        return None
    return _BUSY + (time.perf_counter() - _SINCE if _DEPTH else 0.0)
