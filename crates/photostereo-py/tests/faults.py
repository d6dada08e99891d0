"""A fault injector for Dask batches: kills busy workers of a LocalCluster at random
(SIGKILL, as the kernel's out-of-memory killer or a lost node would), used by
``test_dask.py`` and by ``scripts/dask_faults.py`` (the 100-target run)."""

from __future__ import annotations

import os
import random
import signal
import threading
import time
from pathlib import Path

import numpy as np


class Killer(threading.Thread):
    """Kill up to ``kills`` workers, each one seen running a ``_run_one`` task, waiting
    ``gap`` = (min, max) seconds between kills (drawn with ``seed``). ``killed`` lists
    (address, pid) of the workers killed."""

    def __init__(self, client, kills: int, gap=(0.2, 0.8), seed: int = 0):
        super().__init__(daemon=True)
        self.client, self.kills, self.gap = client, kills, gap
        self.rng = random.Random(seed)
        self.killed: list[tuple[str, int]] = []
        self.done = threading.Event()

    def busy(self) -> list[str]:
        return [
            addr
            for addr, keys in self.client.processing().items()
            if any("_run_one" in str(k) for k in keys)
        ]

    def run(self) -> None:
        while not self.done.is_set() and len(self.killed) < self.kills:
            time.sleep(self.rng.uniform(*self.gap))
            try:
                busy = self.busy()
                if not busy:
                    continue
                addr = self.rng.choice(busy)
                pid = self.client.run(os.getpid, workers=[addr])[addr]
            except Exception:  # the worker went away meanwhile: try again later
                continue
            os.kill(pid, signal.SIGKILL)
            self.killed.append((addr, pid))


def torn_or_left(out: Path) -> list[str]:
    """Files in ``out`` that a killed writer could have left: temporary names."""
    return [p.name for p in out.iterdir() if ".tmp-" in p.name]


def differences(result: dict, out: Path, want: dict, want_dir: Path) -> list[str]:
    """How a batch run's result and files differ from a single-process run's (empty when
    they are the same): figures, normals, depth and confidence bit for bit, no
    temporary file left."""
    diff = []
    if result.get("figures") != want.get("figures"):
        diff.append("figures differ")
    for f in ("normals.npy", "depth.npy", "confidence.npy"):
        a, b = np.load(out / f), np.load(want_dir / f)
        if a.shape != b.shape or not np.array_equal(a, b, equal_nan=True):
            diff.append(f"{f} differs")
    left = torn_or_left(out)
    if left:
        diff.append(f"temporary files left: {left}")
    return diff
