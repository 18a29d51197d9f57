"""Rendering the identification report's figures to PNG images.

:class:`_Renderer` makes matplotlib figures with the object API (no pyplot, so the
caller's backend is left alone) and saves them as PNG, each a
:class:`~simplexspline.aero.report.document.Figure` block; :func:`_render` runs the report's
figure jobs, in forked worker processes where the platform has ``fork``.
"""

from __future__ import annotations

import io
from collections.abc import Callable

from simplexspline._workers import ignore_interrupts
from simplexspline.aero.report.document import Figure

#: Dots per inch of the PNG figures.
DPI = 90

#: Settings the figures are made with (matplotlib's rc parameters, for the jobs only: the
#: caller's are left as they were). Titles at a fixed height above their axes: matplotlib
#: otherwise places every title clear of the x axis's tick labels by measuring them
#: (``_update_title_position``), a quarter of the report's drawing time (the main job's 46
#: figures: 12.6-15.8 -> 9.5-12.1 s in one process; 40 of them the same to the byte, the
#: 3-D slices' titles a few pixels higher). None of these axes has ticks above it.
RC = {"axes.titley": 1.0}


class _Renderer:
    """Makes matplotlib figures (object API, no pyplot) and renders them to PNG bytes."""

    @staticmethod
    def new(width: float, height: float, *, left: float = 0.75, right: float = 0.2,
            bottom: float = 0.6, top: float = 0.3, wspace: float = 0.3,
            hspace: float = 0.35):
        """A figure with fixed margins in inches (no layout engine: twice as fast)."""
        from matplotlib.figure import Figure, SubplotParams

        pars = SubplotParams(left=left / width, right=1.0 - right / width,
                             bottom=bottom / height, top=1.0 - top / height,
                             wspace=wspace, hspace=hspace)
        return Figure(figsize=(width, height), dpi=DPI, subplotpars=pars)

    @staticmethod
    def save(fig, name: str, caption: str) -> Figure:
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=DPI, pil_kwargs={"compress_level": 2})
        return Figure(name, caption, buf.getvalue())


#: Figure jobs of the report being written; set before forking the rendering workers,
#: which inherit it (the jobs hold closures over the data, nothing is pickled).
_JOBS: list = []


def _job(job: Callable):
    """Run one figure job with :data:`RC`."""
    import matplotlib

    with matplotlib.rc_context(RC):
        return job()


def _run_job(index: int):
    return _job(_JOBS[index][1])


def _render(jobs: list, workers: int, say: Callable[[str], None]) -> list:
    """Run the figure jobs ``(label, callable)``; forked worker processes when
    ``workers > 1`` and the platform has ``fork``, else (or on pool failure) serially."""
    global _JOBS
    out: list = [None] * len(jobs)
    done = [False] * len(jobs)
    if workers > 1 and len(jobs) > 2:
        import multiprocessing
        import warnings
        from concurrent.futures import ProcessPoolExecutor, as_completed
        from concurrent.futures.process import BrokenProcessPool

        try:
            ctx = multiprocessing.get_context("fork")
        except ValueError:
            ctx = None
        if ctx is not None:
            _JOBS = jobs
            try:
                with warnings.catch_warnings():
                    # Python >= 3.12 warns about fork() in a multi-threaded process; the
                    # workers only run numpy and matplotlib
                    warnings.simplefilter("ignore", DeprecationWarning)
                    with ProcessPoolExecutor(min(workers, len(jobs)), mp_context=ctx,
                                             initializer=ignore_interrupts) as pool:
                        futures = {pool.submit(_run_job, i): i for i in range(len(jobs))}
                        for fut in as_completed(futures):
                            i = futures[fut]
                            out[i], done[i] = fut.result(), True
                            say(f"report: figure {sum(done)}/{len(jobs)} ({jobs[i][0]})")
            except (BrokenProcessPool, OSError):
                pass  # render what is missing serially
            finally:
                _JOBS = []
    for i, (label, job) in enumerate(jobs):
        if not done[i]:
            out[i], done[i] = _job(job), True
            say(f"report: figure {sum(done)}/{len(jobs)} ({label})")
    return out
