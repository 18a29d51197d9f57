"""Killing the installed commands (SIGINT, SIGKILL) at several moments (issue 18).

Each case runs a command to completion (the previous output), runs it again and sends a
signal to its process group at a chosen moment, then checks that the previous output is
byte for byte intact (or, when the signal came after the last rename, the new output
whole) and that only hidden temporaries are beside it; SIGINT inside ``main()`` must give
exit 130 and one line; so must SIGINT while the package imports (the launcher defers it
to the end of the imports). Only during interpreter exit is it Python's own
KeyboardInterrupt, exit -2. A last run must complete and leave no temporary
behind (a killed run's temporaries, whose writer is gone, are removed by the next write).

Moments: ``start`` (0.3 s: Python still importing), ``mid`` (halfway between the end of
the imports and the end of the first run) and ``write`` (as soon as the output's temporary
file or staging directory appears). For the ``write`` moment the command runs on a slow
disk: every ``os.replace`` waits a second first, so that the signal lands while the output
is being written however loaded the machine is. (Without it, a write of a few
milliseconds could end, and the interpreter exit past its last bytecode, between the
watcher seeing the temporary and the signal: a SIGINT then never reaches Python, exit 0.)
The default suite kills ``identify`` twice while it writes; the full sweep (three commands
x two signals x three moments) is marked slow.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from simplexspline.aero.data.flight_data import SCHEMA_VERSION, write_flight_data


pytestmark = pytest.mark.skipif(os.name != "posix", reason="POSIX signals and process groups")

CLI = [sys.executable, "-m", "simplexspline"]

#: The command through the same launcher, on a slow disk (each rename waits a second).
SLOW_WRITE_CLI = [sys.executable, "-c", (
    "import os, sys, time\n"
    "_replace = os.replace\n"
    "def _slow_replace(*args, **kwargs):\n"
    "    time.sleep(1.0)\n"
    "    return _replace(*args, **kwargs)\n"
    "os.replace = _slow_replace\n"
    "from simplexspline.launcher import main\n"
    "raise SystemExit(main())\n")]


def _snapshot(root: Path) -> dict:
    """Relative path -> bytes of every file under ``root`` (directories as None)."""
    return {str(p.relative_to(root)): (None if p.is_dir() else p.read_bytes())
            for p in sorted(root.rglob("*"))}


def _temporaries(root: Path) -> list:
    """The hidden temporaries under ``root``; the command under test creates and removes
    them while this walks (a directory vanishing mid-walk: walk again)."""
    for _ in range(100):
        try:
            return sorted(str(p.relative_to(root)) for p in root.rglob(".*")
                          if p.name.endswith((".tmp", ".old"))
                          or p.name.startswith(".identify."))
        except FileNotFoundError:
            continue
    raise AssertionError(f"{root} kept changing during 100 walks")


def _run(args: list, cwd: Path) -> subprocess.CompletedProcess:
    res = subprocess.run(CLI + args, cwd=cwd, capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    return res


def _default_sigint() -> None:
    """SIGINT as a terminal delivers it, even when the tests run as a background job (whose
    children inherit SIGINT ignored, and Python then installs no handler)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _killed(args: list, cwd: Path, sig: int, moment: str, watch: Path,
            seconds: tuple[float, float]):
    """Run the command and send ``sig`` to its process group at ``moment``; returns
    (exit code, stderr, whether the signal was sent before the command ended)."""
    old = set(_temporaries(watch))                     # a previous killed run's
    proc = subprocess.Popen((SLOW_WRITE_CLI if moment == "write" else CLI) + args, cwd=cwd, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=_default_sigint)
    t0 = time.monotonic()
    # midway between the end of the imports and the end of the first run
    due = {"start": 0.3, "mid": seconds[0] + 0.5 * (seconds[1] - seconds[0])}.get(moment)
    sent = False
    while proc.poll() is None and time.monotonic() - t0 < 600:
        if due is not None and time.monotonic() - t0 >= due \
                or due is None and set(_temporaries(watch)) - old:
            os.killpg(proc.pid, sig)
            sent = True
            break
        time.sleep(0.005)
    _out, err = proc.communicate(timeout=600)
    return proc.returncode, err, sent


def _case(command: str, kills: list, tmp_path: Path, sources: dict,
          source: str | None = None) -> None:
    """Run ``command`` to completion, then killed at each ``(signal, moment)`` of ``kills``
    in turn (the previous output intact after each), then to completion again (clean).
    ``source``: the entry of ``sources`` giving its arguments (default: ``command``)."""
    work = tmp_path / "work"
    work.mkdir()
    args, output = sources[source or command](work)
    t0 = time.monotonic()
    subprocess.run(CLI[:1] + ["-c", "import simplexspline.cli"], check=True, timeout=300)
    imports = time.monotonic() - t0
    t0 = time.monotonic()
    _run(args, work)                                   # the previous output
    seconds = (imports, time.monotonic() - t0)
    before = _snapshot(work)
    for sig, moment in kills:
        rc, err, sent = _killed(args, work, sig, moment, output if output.is_dir() else work,
                                seconds)
        assert sent, f"{command} ended before the {moment} moment: {err}"
        if sig == signal.SIGKILL:
            assert rc == -signal.SIGKILL
        elif moment in ("write", "start") or rc == 130:   # one line, exit 130
            lines = err.strip().splitlines()
            assert rc == 130 and lines in ([f"simplexspline {command}: interrupted"],
                                           ["simplexspline: interrupted"]), err
        else:   # after main() (interpreter exit): Python's own
            assert rc == -signal.SIGINT, err
        after = _snapshot(work)
        leftovers = [k for k in after if k not in before]
        assert all(any(part.startswith(".") for part in Path(k).parts)
                   for k in leftovers), leftovers       # only hidden temporaries
        visible = {k: v for k, v in after.items() if k in before}
        # the previous output intact, or (the signal came after the last rename) the new
        # one whole: every entry there, each file renamed into place complete
        assert visible == before or sorted(visible) == sorted(before) and sig == \
            signal.SIGINT, (command, sig, moment)
    _run(args, work)                                   # the next run cleans up
    assert _temporaries(work) == []
    assert set(_snapshot(work)) == set(before)


@pytest.fixture(scope="module")
def sources(tmp_path_factory):
    """Command -> (work directory -> (arguments, output path))."""
    pytest.importorskip("jsbsim")
    from simplexspline.aero import reconstruct
    from simplexspline.sim import Campaign, ConditionGrid, FlightProtocol

    root = tmp_path_factory.mktemp("kill-sources")
    raw = root / "raw.parquet"
    coefficients = root / "coefficients.parquet"
    df = Campaign("f16", maneuvers=4, seed=3,
                  grid=ConditionGrid(altitudes_m=[3000.0], airspeeds_mps=[160.0, 220.0]),
                  protocol=FlightProtocol(mix={"3211": 1}, sos_duration_s=(15.0, 20.0))
                  ).run(workers=1, progress=False)
    write_flight_data(df, raw)
    rec = reconstruct(df, workers=1).data
    write_flight_data(rec, coefficients, rec.attrs)

    def identify(work):
        return (["identify", str(coefficients), "-o", "out", "--no-select", "--no-report",
                 "--coefficients", "CZ", "--workers", "1", "-q"], work / "out")

    def simulate(work):
        return (["simulate", "--maneuvers", "1", "--workers", "1", "-q", "-o", "sim.parquet"],
                work / "sim.parquet")

    def reconstruct_(work):
        return (["reconstruct", str(raw), "--workers", "1", "-q", "-o", "rec.parquet"],
                work / "rec.parquet")

    def identify_search(work):
        # with the structure search: seconds of work before the write, so that a kill
        # 'mid' run lands there (without it the fit takes 0.25 s after 1.2 s of imports,
        # the write began 0.07 s before 'mid', and a SIGKILL there found the new output
        # already renamed into place in 3 of 7 runs)
        args, out = identify(work)
        return [a for a in args if a != "--no-select"], out

    return {"identify": identify, "identify_search": identify_search, "simulate": simulate,
            "reconstruct": reconstruct_}


def test_kill_identify_while_writing(tmp_path, sources):
    """SIGKILL, then SIGINT, as the output's staging directory appears."""
    _case("identify", [(signal.SIGKILL, "write"), (signal.SIGINT, "write")], tmp_path,
          sources)


@pytest.mark.slow
@pytest.mark.parametrize("command", ["identify", "simulate", "reconstruct"])
def test_kill_sweep(command, tmp_path, sources):
    """Both signals at each moment, one after the other."""
    _case(command, [(sig, moment) for moment in ("start", "mid", "write")
                    for sig in (signal.SIGKILL, signal.SIGINT)], tmp_path, sources,
          source="identify_search" if command == "identify" else None)
