"""The command line's contract: every deliberate failure is one line on stderr and exit code 2.

Bad option values stop before any work starts; operating-system errors (missing paths,
a file where a directory should be, disk full) are one line too, never a traceback.
"""

from __future__ import annotations

import errno
import subprocess
import sys

import pytest

from simplexspline.cli import main, os_error_message


def _one_line(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


@pytest.mark.parametrize("argv, match", [
    (["simulate", "--seed", "-1"], "argument --seed: a seed must be an integer between 0 and"),
    (["simulate", "--seed", "1.5"], "argument --seed: expected an integer, got '1.5'"),
    (["simulate", "--maneuvers", "0"], "argument --maneuvers: expected an integer >= 1"),
    (["simulate", "--noise-scale", "-0.1"], "argument --noise-scale: expected a number >= 0"),
    (["simulate", "--turn-fraction", "2"], "argument --turn-fraction: expected a number from 0"),
    (["simulate", "--workers", "0"], "argument --workers: expected an integer >= 1"),
    (["demo", "--noise", "nan"], "argument --noise: expected a finite number, got 'nan'"),
    (["demo", "--degree", "-2"], "argument --degree: expected an integer >= 0"),
    (["demo", "--samples", "many"], "argument --samples: expected an integer, got 'many'"),
    (["reconstruct", "x.parquet", "--min-duration", "0"], "argument --min-duration: expected a "
     "number > 0"),
    (["identify", "--validation-fraction", "1"], "argument --validation-fraction: expected a "
     "number between 0 and 1"),
    (["identify", "--rounds", "-1"], "argument --rounds: expected an integer >= 0"),
    (["identify", "--no-such-option"], "unrecognized arguments: --no-such-option"),
])
def test_bad_option_values_are_one_line_and_exit_2(argv, match, capsys):
    assert main(argv) == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith(f"simplexspline {argv[0]}: error: ") or \
        line.startswith("simplexspline: error: ")
    assert match in line
    assert "--help" in line


def test_help_and_version_return_0(capsys):
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.startswith("simplexspline ")
    assert main(["demo", "--help"]) == 0


@pytest.mark.parametrize("code, verb, advice", [
    (errno.ENOSPC, "write", "free disk space"),
    (errno.EROFS, "write", "read-only"),
    (errno.EACCES, "write", "permissions"),
    (errno.ENOENT, "read", "check the path"),
    (errno.EIO, "write", "check the path, the permissions and the free space"),
])
def test_os_error_message_names_path_cause_and_fix(code, verb, advice):
    msg = os_error_message(OSError(code, "why", "out/report.html"))
    assert msg.startswith(f"cannot {verb} 'out/report.html': why (errno {code}); ")
    assert advice in msg
    assert "\n" not in msg


def test_an_os_error_in_a_command_is_one_line(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    code = main(["demo", "--samples", "3000", "--cells", "1", "-o", str(blocker / "m.json")])
    assert code == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith("simplexspline demo: error: cannot ")
    assert str(blocker) in line
    assert blocker.read_text() == "not a directory"


def test_python_dash_m_runs_the_cli():
    res = subprocess.run([sys.executable, "-m", "simplexspline.cli", "--version"],
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 0
    assert res.stdout.startswith("simplexspline ")
