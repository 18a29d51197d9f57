"""Worker processes: how they start, and Ctrl-C left to their parent.

**Start.** The package's process pools (the campaign simulator, the reconstruction, the
coefficients' searches) take their context from :func:`process_context`: a fork server
where the platform has one, else ``spawn``. A spawned worker starts a fresh interpreter and
imports numpy, scipy, pandas and the package: about 1.5 s of CPU each, and the main job
starts ten of them (2 + 2 + 6: measured 4.6 s of wall time and 9 s of CPU for the six
search workers on 2 cores). The fork server is one clean process that imports the
package's worker modules (:data:`PRELOAD`) once and forks every worker from there, so a
worker starts in milliseconds with nothing to import. Unlike a plain ``fork`` of the
caller, the server holds none of the calling program's threads, open files or state; like
``spawn``, workers see the package as it is installed, not the caller's changes to it.

**Ctrl-C.** A terminal's Ctrl-C reaches every process of its group: without this, each
worker of a process pool prints its own KeyboardInterrupt traceback. Pools are started with
:func:`ignore_interrupts` as initializer; the parent alone turns the interrupt into the
command line's one-line "interrupted" message (exit code 130). The fork server ignores
SIGINT by itself.
"""

from __future__ import annotations

import multiprocessing
import signal

__all__ = ["PRELOAD", "process_context", "ignore_interrupts", "interrupt_handler"]

#: Modules the fork server imports before it forks the workers: those the package's
#: pools run, and ``scipy.signal``, which the reconstruction workers' control smoothing
#: imports on first use (0.5-0.8 s each; a module whose optional dependencies are
#: missing is skipped by the server).
PRELOAD: tuple = ("simplexspline.aero.identify",
                  "simplexspline.aero.reconstruction.reconstruct",
                  "simplexspline.sim.campaign",
                  "scipy.signal")


def process_context() -> multiprocessing.context.BaseContext:
    """The multiprocessing context of the package's process pools.

    Returns
    -------
    multiprocessing.context.BaseContext
        ``forkserver`` with :data:`PRELOAD` where the platform has it (Linux, macOS), else
        ``spawn`` (Windows).

    Notes
    -----
    The fork server is one per Python process. Its preload list is set here, before the
    first pool starts it; a server the calling program started earlier keeps its own
    list (its workers then import what they need, as spawned ones do).
    """
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(list(PRELOAD))
    return ctx


def ignore_interrupts() -> None:
    """Pool initializer: this worker ignores SIGINT (its parent handles Ctrl-C)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def interrupt_handler() -> object:
    """The SIGINT handler of this process (for tests and diagnostics)."""
    return signal.getsignal(signal.SIGINT)
