"""SIGTERM at a random moment of a short CLI command, many times: is every one handled?

    python scripts/signal_at_random.py [--trials N] [--within LO HI] [--after-start]
                                       [--command "ARGS"]

Each trial runs a terrascape command in a new process (by default ``render MAP -o
OUT/day.mp4 --day-cycle 24h --frames 2000``: 64×40 frames, a few seconds; ``--command``
gives another, with ``{map}`` for a 65² fBm map and ``{out}`` for the trial's own empty
folder), waits until a file appears in that folder (an unfinished output's temporary
file; with ``--after-start``, only until the process has started), sleeps a random time
between LO and HI seconds (default 0–0.3: the kernels are still being loaded then) and
sends SIGTERM. A trial is counted as failed when the command
did not exit with 143 (or 0, when it finished before the signal and wrote its outputs),
printed a dropped exception ("Exception ignored") or a traceback, or left an unfinished
file (a temporary, or any file at all after exit 143) half a second after it exited.
Prints the failed trials and their count.
Run it with ``PYTHONPATH`` set to another version's ``src`` to compare.
"""

from __future__ import annotations

import argparse
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=40)
    parser.add_argument("--within", type=float, nargs=2, default=(0.0, 0.3),
                        metavar=("LO", "HI"))
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--after-start", action="store_true")
    parser.add_argument("--command", default="render {map} -o {out}/day.mp4 --size 64x40 -q "
                        "--technique plain --day-cycle 24h --frames 2000")
    args = parser.parse_args()
    rng = random.Random(args.seed)
    folder = Path(tempfile.mkdtemp())
    hm = folder / "map" / "hm.npy"
    hm.parent.mkdir()
    np.save(hm, np.random.default_rng(1).random((65, 65), dtype=np.float32) * 10)
    failed = finished = 0
    for trial in range(args.trials):
        out = folder / f"t{trial}"
        out.mkdir()
        command = [a.format(map=hm, out=out) for a in args.command.split()]
        proc = subprocess.Popen(
            [sys.executable, "-c", "from terrascape.cli import main; main()", *command],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=os.environ)
        while not args.after_start and proc.poll() is None and not any(out.iterdir()):
            time.sleep(0.002)
        time.sleep(rng.uniform(*args.within))
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=600)
        time.sleep(0.5)
        left = sorted(str(p.relative_to(out)) for p in out.rglob("*"))
        unfinished = [name for name in left if ".part" in name or ".bak" in name]
        finished += proc.returncode == 0
        if (proc.returncode not in (0, 128 + signal.SIGTERM) or unfinished
                or (proc.returncode != 0 and left) or "Exception ignored" in err
                or "Traceback" in err):
            failed += 1
            print(f"trial {trial}: exit {proc.returncode}, files left {left[:5]}, "
                  f"stderr: {err.strip()[-1500:]}")
    print(f"{finished} of {args.trials} finished before the signal")
    print(f"{failed} of {args.trials} trials failed")


if __name__ == "__main__":
    main()
