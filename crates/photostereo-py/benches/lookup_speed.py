"""Lookup speed through Python next to the CLI's, on the same data (run by hand):

    python crates/photostereo-py/benches/lookup_speed.py [SIZE] [REPEATS]
    python crates/photostereo-py/benches/lookup_speed.py bench-row [REPEATS]

Renders a shiny vase (SIZE², 16 lights) and its calibration sphere (radius 0.3 × SIZE)
with `photostereo synth`, then REPEATS rounds, each in a random order (so that neither
side always runs right after the other's process):

* CLI: `photostereo run --sphere` in its own process; its `lookup` stage seconds from
  run.json (the library's `lut::solve`, timed inside the process);
* Python: `Table.lookup(dataset, spatial=False)` (the lookup alone) on the loaded
  dataset, wall time of the call (the argument checks, the one copy of the images into
  the library, the lookup with the GIL released and the hand-over of the outputs), and
  the process CPU seconds it used. Since issue 25 the table's prepared `lut::Lookup` is
  reused from the second call on, where the CLI's stage prepares it every run;
* Python `photostereo.run(..., sphere=...)`: the same pipeline as the CLI inside the
  Python process, its own `lookup` stage seconds.

Prints the median and best of each, and the median of the per-round ratios Python / CLI.
On a loaded machine wall times swing by 2×: compare the ratios, not the seconds.

`bench-row` compares CPU seconds instead (what a busy machine does not change): the CLI's
`photostereo bench --only lookup` row (1024² shiny vase, K = 16, table from a sphere of
radius 150 at its known circle; "cpu s/run" = CPU time of all threads per call) next to
`Table.lookup` on the same scene rendered by `photostereo synth` (16-bit PNGs) with the
table built at the same circle, alternating, REPEATS timed calls each.
"""

import json
import os
import random
import resource
import statistics as st
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import photostereo as ps

REPO = Path(__file__).resolve().parents[3]
BIN = os.environ.get("PHOTOSTEREO_BIN", str(REPO / "target" / "release" / "photostereo"))


def cpu_seconds():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def lookup_stage(out):
    stages = json.loads((out / "run.json").read_text())["stages"]
    return next(s["seconds"] for s in stages if s["stage"] == "lookup")


def main():
    size = int(sys.argv[1]) if len(sys.argv) > 1 else 512
    reps = int(sys.argv[2]) if len(sys.argv) > 2 else 11
    d = Path(tempfile.mkdtemp())
    vase, sphere = d / "vase", d / "vase" / "sphere"
    subprocess.run([BIN, "-q", "synth", "--shape", "vase", "--material", "plastic", "-k", "16",
                    "--size", str(size), "--calib-sphere", str(0.3 * size), "-o", vase],
                   check=True)
    ds = ps.load_dataset(vase)
    table = ps.calibrate(sphere)
    px = int(ds.mask.sum())
    t = {"cli": [], "py": [], "py_cpu": [], "py_run": []}
    rng = random.Random(1)
    for _ in range(reps):
        sides = ["cli", "py", "py_run"]
        rng.shuffle(sides)
        for side in sides:
            if side == "cli":
                subprocess.run([BIN, "-q", "run", "--sphere", sphere, vase, "-o", d / "cli"],
                               check=True)
                t["cli"].append(lookup_stage(d / "cli"))
            elif side == "py":
                c0, t0 = cpu_seconds(), time.perf_counter()
                table.lookup(ds, spatial=False)
                t["py"].append(time.perf_counter() - t0)
                t["py_cpu"].append(cpu_seconds() - c0)
            else:
                ps.run(vase, d / "py", sphere=sphere)
                t["py_run"].append(lookup_stage(d / "py"))
    print(f"{size}x{size} vase, {px} mask pixels, K = 16, table of {len(table)} entries, "
          f"{reps} rounds, load average {os.getloadavg()[0]:.1f}")
    for name, label in [("cli", "CLI run, lookup stage"), ("py", "Python Table.lookup"),
                        ("py_cpu", "  its CPU seconds"), ("py_run", "Python run, lookup stage")]:
        v = t[name]
        print(f"{label:26s} median {st.median(v):.4f} s, best {min(v):.4f} s")
    for name in ["py", "py_run"]:
        pairs = [p / c for p, c in zip(t[name], t["cli"])]
        print(f"{name} / cli: median of rounds {st.median(pairs):.3f}, "
              f"of medians {st.median(t[name]) / st.median(t['cli']):.3f}, "
              f"of bests {min(t[name]) / min(t['cli']):.3f}")


def bench_row(reps):
    d = Path(tempfile.mkdtemp())
    vase = d / "vase"
    subprocess.run([BIN, "-q", "synth", "--shape", "vase", "-k", "16", "--size", "1024",
                    "--calib-sphere", "150", "-o", vase], check=True)
    ds = ps.load_dataset(vase)
    k, h, w = ps.load_dataset(vase / "sphere").images.shape
    table = ps.calibrate(vase / "sphere", circle=(w / 2, h / 2, 150.0))
    table.lookup(ds, spatial=False)  # warm-up, as the bench's untimed preparation
    cli, py = [], []
    for _ in range(3):
        r = subprocess.run([BIN, "bench", "--only", "lookup", "--repeat", str(reps)],
                           check=True, capture_output=True, text=True)
        row = next(line for line in r.stdout.splitlines() if line.startswith("lookup"))
        cli.append(float(row.split()[3]))
        for _ in range(reps):
            c0 = cpu_seconds()
            table.lookup(ds, spatial=False)
            py.append(cpu_seconds() - c0)
    print(f"1024x1024 vase, {int(ds.mask.sum())} mask pixels, K = 16, load average "
          f"{os.getloadavg()[0]:.1f}; CPU seconds per lookup (all threads)")
    print(f"CLI bench lookup row: median {st.median(cli):.4f} (of {len(cli)} runs of {reps})")
    print(f"Python Table.lookup:  median {st.median(py):.4f} (of {len(py)} calls)")
    print(f"Python / CLI CPU: {st.median(py) / st.median(cli):.3f}")


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "bench-row":
        bench_row(int(sys.argv[2]) if len(sys.argv) > 2 else 3)
    else:
        main()
