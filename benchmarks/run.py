"""Run every benchmark and print their tables: `make bench` (or `python benchmarks/run.py`).

Pass --quick for a smoke run with smaller sizes.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main(argv: list[str]) -> int:
    quick = "--quick" in argv
    runs = [
        [sys.executable, str(HERE / "bench_fit.py")] + (["--quick", "--repeats", "3"] if quick else []),
        [sys.executable, str(HERE / "bench_sim.py")] + (["--maneuvers", "20", "--repeats", "1"] if quick else []),
        [sys.executable, str(HERE / "bench_reconstruction.py")] + (["--maneuvers", "10"] if quick else []),
        [sys.executable, str(HERE / "bench_edge.py")] + (["--seeds", "1"] if quick else []),
        [sys.executable, str(HERE / "bench_compare.py")] + (["--quick"] if quick else []),
    ]
    status = 0
    for cmd in runs:
        print("$ " + " ".join(Path(c).name if c.endswith(".py") else c for c in cmd[1:]), flush=True)
        status |= subprocess.call(cmd)
        print(flush=True)
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
