#!/usr/bin/env python3
"""The 100-target Dask batch under repeated worker kills (issue 26 item 6).

Renders N small targets (four shapes, noisy, one calibration sphere) with the CLI, runs
each in one process (``photostereo.run``), then all of them with
``photostereo.dask.run_many`` on a LocalCluster of W worker processes while a fault
injector SIGKILLs a busy worker at random, up to KILLS times. Checks that every target
completes and equals its single-process run bit for bit (normals, depth, confidence,
run.json figures) with no temporary file left, and that each run's memory budget was
its worker's share. Prints one summary line; exit status 1 on any difference.

    python3 scripts/dask_faults.py --targets 100 --workers 3 --kills 8 [--work DIR]

Needs the package with dask (``pip install ./crates/photostereo-py[dask]``) and the
CLI (``cargo build --release``; or ``PHOTOSTEREO_BIN``). The pytest version, smaller, is
``test_repeated_kills_on_three_workers_lose_nothing`` in crates/photostereo-py/tests.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "crates" / "photostereo-py" / "tests"))

import dask  # noqa: E402
from dask.distributed import Client, LocalCluster  # noqa: E402

import photostereo as ps  # noqa: E402
from photostereo.dask import run_many  # noqa: E402
from faults import Killer, differences  # noqa: E402

SHAPES = ["blob", "vase", "sphere", "bowl"]


def synth(bin_: str, out: Path, *args: str) -> Path:
    subprocess.run([bin_, "-q", "synth", *args, "-k", "12", "-o", str(out)], check=True)
    return out


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--targets", type=int, default=100)
    p.add_argument("--workers", type=int, default=3)
    p.add_argument("--kills", type=int, default=8)
    p.add_argument("--size", type=int, default=96, help="target image side (px)")
    p.add_argument("--seed", type=int, default=0, help="seed of the kills' timing and choice")
    p.add_argument("--work", help="working folder (default: a temporary one)")
    a = p.parse_args()
    bin_ = os.environ.get("PHOTOSTEREO_BIN", str(REPO / "target" / "release" / "photostereo"))
    work = Path(a.work or tempfile.mkdtemp(prefix="dask-faults-"))
    t0 = time.monotonic()
    sphere = synth(bin_, work / "vase", "--shape", "vase", "--material", "plastic",
                   "--size", "96", "--calib-sphere", "40") / "sphere"
    targets = [
        synth(bin_, work / "targets" / f"t{i:03}", "--shape", SHAPES[i % 4], "--material",
              "plastic", "--size", str(a.size), "--noise", "0.005", "--seed", str(100 + i))
        for i in range(a.targets)
    ]
    table = ps.calibrate(sphere)
    single = {t.name: ps.run(t, work / "single" / t.name, sphere=table) for t in targets}
    t1 = time.monotonic()
    with dask.config.set({"distributed.scheduler.allowed-failures": 2 * a.kills + 3}):
        cluster = LocalCluster(n_workers=a.workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
        try:
            limits = {w["memory_limit"] for w in client.scheduler_info()["workers"].values()}
            killer = Killer(client, kills=a.kills, gap=(0.3, 1.5), seed=a.seed)
            killer.start()
            results = run_many(targets, work / "batch", sphere=table, client=client)
            killer.done.set()
            killer.join()
        finally:
            client.close()
            cluster.close()
    t2 = time.monotonic()
    bad = {}
    for r, t in zip(results, targets):
        d = differences(r, work / "batch" / t.name, single[t.name], work / "single" / t.name)
        if r.get("dataset") != t.name:
            d.append(f"result for {r.get('dataset')}")
        if d:
            bad[t.name] = d
    print(f"{len(results)} of {len(targets)} targets done, {len(bad)} differ from the "
          f"single-process runs; {len(killer.killed)} workers killed; {a.workers} workers, "
          f"memory limit per worker {sorted(limits)} B (each run's budget); batch "
          f"{t2 - t1:.1f} s, setup and single runs {t1 - t0:.1f} s; work folder {work}")
    for name, d in bad.items():
        print(f"  {name}: {'; '.join(d)}")
    return 1 if bad or len(results) != len(targets) else 0


if __name__ == "__main__":
    sys.exit(main())
