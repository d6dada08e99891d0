"""Lookup speed through Python next to the CLI's, on the same data (run by hand):

    python crates/photostereo-py/benches/lookup_speed.py [SIZE] [REPEATS]

Renders a shiny vase (SIZE², 16 lights) and its calibration sphere (radius 0.3 × SIZE)
with `photostereo synth`, then alternates, REPEATS times: the CLI's `photostereo run
--sphere` (its `lookup` stage seconds, from run.json) and `Table.lookup` from Python on
the loaded dataset (wall time of the call, the array copy into the library included).
Prints the best of each and the ratio.
"""

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import photostereo as ps

REPO = Path(__file__).resolve().parents[3]
BIN = os.environ.get("PHOTOSTEREO_BIN", str(REPO / "target" / "release" / "photostereo"))


def main():
    size = int(sys.argv[1]) if len(sys.argv) > 1 else 512
    reps = int(sys.argv[2]) if len(sys.argv) > 2 else 5
    d = Path(tempfile.mkdtemp())
    subprocess.run([BIN, "-q", "synth", "--shape", "vase", "--material", "plastic", "-k", "16",
                    "--size", str(size), "--calib-sphere", str(0.3 * size), "-o", d / "vase"],
                   check=True)
    ds = ps.load_dataset(d / "vase")
    table = ps.calibrate(d / "vase" / "sphere")
    px = int(ds.mask.sum())
    cli, py = [], []
    for i in range(reps):
        subprocess.run([BIN, "-q", "run", "--sphere", d / "vase" / "sphere", d / "vase",
                        "-o", d / "out"], check=True)
        stages = json.loads((d / "out" / "run.json").read_text())["stages"]
        cli.append(next(s["seconds"] for s in stages if s["stage"] == "lookup"))
        t = time.perf_counter()
        table.lookup(ds)
        py.append(time.perf_counter() - t)
    c, p = min(cli), min(py)
    print(f"{size}x{size} vase, {px} mask pixels, K = 16, table of {len(table)} entries")
    print(f"CLI lookup stage:     best {c:.4f} s ({px / c / 1e6:.2f} Mpx/s) of {reps}")
    print(f"Python Table.lookup:  best {p:.4f} s ({px / p / 1e6:.2f} Mpx/s) of {reps}")
    print(f"Python / CLI time: {p / c:.3f}")


if __name__ == "__main__":
    main()
