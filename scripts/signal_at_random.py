"""SIGTERM at a random moment of a short CLI command, many times: is every one handled?

    python scripts/signal_at_random.py [--trials N] [--within LO HI]

Each trial runs ``terrascape render MAP -o day.mp4 --day-cycle 24h --frames 2000`` (64×40
frames, a few seconds) in a new process, waits until its unfinished output's temporary file
appears, sleeps a random time between LO and HI seconds (default 0–0.3: the kernels are
still being loaded then) and sends SIGTERM. A trial is counted as failed when the command
did not exit with 143, printed a dropped exception ("Exception ignored"), or left any file
in its folder half a second after it exited. Prints the failed trials and their count.
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
    args = parser.parse_args()
    rng = random.Random(args.seed)
    folder = Path(tempfile.mkdtemp())
    hm = folder / "map" / "hm.npy"
    hm.parent.mkdir()
    np.save(hm, np.random.default_rng(1).random((65, 65), dtype=np.float32) * 10)
    failed = 0
    for trial in range(args.trials):
        out = folder / f"t{trial}"
        out.mkdir()
        proc = subprocess.Popen(
            [sys.executable, "-c", "from terrascape.cli import main; main()", "render", str(hm),
             "-o", str(out / "day.mp4"), "--size", "64x40", "-q", "--technique", "plain",
             "--day-cycle", "24h", "--frames", "2000"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=os.environ)
        while proc.poll() is None and not any(out.iterdir()):
            time.sleep(0.002)
        time.sleep(rng.uniform(*args.within))
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
        time.sleep(0.5)
        left = sorted(p.name for p in out.iterdir())
        if proc.returncode != 128 + signal.SIGTERM or "Exception ignored" in err or left:
            failed += 1
            print(f"trial {trial}: exit {proc.returncode}, files left {left}, "
                  f"dropped exception: {'Exception ignored' in err}")
    print(f"{failed} of {args.trials} trials failed")


if __name__ == "__main__":
    main()
