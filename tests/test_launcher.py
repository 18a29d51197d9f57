"""The ``simplexspline`` command's launcher: a Ctrl-C at any moment gives one line.

Importing the command line takes seconds; the launcher defers an interrupt that arrives
meanwhile and stops with exit code 130 and "simplexspline: interrupted" (issue 18: early
Ctrl-C printed numpy's and the workers' import tracebacks).
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest

pytestmark = pytest.mark.skipif(os.name != "posix", reason="POSIX signals")


def _python(code: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True,
                          text=True, timeout=300)


def test_package_import_is_light():
    """``import simplexspline`` loads neither numpy nor the spline layer until a public
    name is used: the window in which an interrupt cannot be caught stays milliseconds."""
    res = _python("""
        import sys
        import simplexspline, simplexspline.launcher
        assert "numpy" not in sys.modules and "simplexspline.spline" not in sys.modules
        from simplexspline import SplineSpace, InputError
        assert SplineSpace.__module__.startswith("simplexspline.spline")
        assert issubclass(InputError, simplexspline.SimplexSplineError)
        assert "Triangulation" in dir(simplexspline)
        try:
            simplexspline.no_such_name
        except AttributeError as exc:
            assert "no attribute 'no_such_name'" in str(exc)
        else:
            raise SystemExit("no AttributeError")
    """)
    assert res.returncode == 0, res.stderr


def test_interrupt_while_importing_the_command_line():
    """A SIGINT delivered in the middle of the command line's import (here: as numpy's
    C extension starts loading) ends the command with one line and exit code 130."""
    res = _python("""
        import os, signal, sys
        signal.signal(signal.SIGINT, signal.default_int_handler)

        class Interrupt:                  # sends SIGINT when numpy starts importing
            def find_spec(self, name, path=None, target=None):
                if name == "numpy.core._multiarray_umath" or name == "numpy._core._multiarray_umath":
                    os.kill(os.getpid(), signal.SIGINT)
                return None

        sys.meta_path.insert(0, Interrupt())
        from simplexspline.launcher import main
        sys.exit(main(["--version"]))
    """)
    assert res.returncode == 130, res.stderr
    assert res.stderr.strip().splitlines() == ["simplexspline: interrupted"]
    assert res.stdout == ""           # the command itself did not run


def test_launcher_runs_the_command_line():
    res = subprocess.run([sys.executable, "-m", "simplexspline", "--version"],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0 and res.stdout.startswith("simplexspline ")
    res = subprocess.run([sys.executable, "-m", "simplexspline", "identify", "missing.parquet",
                          "-o", "out"], capture_output=True, text=True, timeout=300)
    assert res.returncode == 2 and "Traceback" not in res.stderr
