"""photostereo.dask.run_many on LocalClusters of two and three worker processes: the same
results as one process; a worker killed mid-run, or workers killed again and again at
random, lose nothing. Dask is required (the test script installs it): a missing dask
fails here, it does not skip. The 100-target run is ``scripts/dask_faults.py``."""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import dask
import numpy as np
import pytest
from dask.distributed import Client, LocalCluster

import photostereo as ps
from photostereo.dask import run_many

from conftest import synth
from faults import Killer, differences

SHAPES = [("blob", "0"), ("vase", "1"), ("sphere", "2"), ("bowl", "3"), ("blob", "4"), ("vgroove", "5")]


@pytest.fixture(scope="module")
def targets(data, cli):
    """Six shiny targets under the vase's lights (noisy: every one differs)."""
    root = data["root"] / "batch"
    out = []
    for i, (shape, seed) in enumerate(SHAPES):
        out.append(
            synth(cli, root / f"t{i}-{shape}", shape, "plastic", 96,
                  "--noise", "0.005", "--seed", seed)
        )
    return out


@pytest.fixture(scope="module")
def single(targets, data, tmp_path_factory):
    """The single-process results: photostereo.run with the sphere directory."""
    out = tmp_path_factory.mktemp("single")
    return {t.name: (ps.run(t, out / t.name, sphere=data["sphere"]), out / t.name) for t in targets}


@pytest.fixture(scope="module")
def client():
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                           dashboard_address=None)
    c = Client(cluster)
    yield c
    c.close()
    cluster.close()


def check_equal(results, targets, out: Path, single):
    assert len(results) == len(targets)
    for r, t in zip(results, targets):
        want, want_dir = single[t.name]
        assert r["dataset"] == t.name
        assert r["figures"] == want["figures"]
        for f in ("normals.npy", "depth.npy", "confidence.npy"):
            np.testing.assert_array_equal(np.load(out / t.name / f), np.load(want_dir / f))
        left = [p.name for p in (out / t.name).iterdir() if ".tmp-" in p.name]
        assert not left, f"half-written files left: {left}"


def test_local_cluster_equals_single_process(targets, single, data, client, tmp_path):
    results = run_many(targets, tmp_path, sphere=data["sphere"], client=client)
    check_equal(results, targets, tmp_path, single)


def test_killed_worker_loses_nothing(targets, single, data, client, tmp_path):
    pids = client.run(os.getpid)  # {worker address: pid}
    assert len(pids) == 2
    table = ps.calibrate(data["sphere"])
    killed = {}

    def killer():
        # kill the first worker seen computing a task of ours
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not killed:
            for addr, keys in client.processing().items():
                if any("_run_one" in str(k) for k in keys) and addr in pids:
                    os.kill(pids[addr], signal.SIGKILL)
                    killed[addr] = pids[addr]
                    return
            time.sleep(0.005)

    import threading

    th = threading.Thread(target=killer)
    th.start()
    results = run_many(targets, tmp_path, sphere=table, client=client)
    th.join()
    assert killed, "no worker was seen computing: nothing was killed"
    print(f"killed worker {killed}")
    check_equal(results, targets, tmp_path, single)


def test_duplicate_folder_names_refused(data, tmp_path, client):
    a = tmp_path / "a" / "x"
    b = tmp_path / "b" / "x"
    with pytest.raises(ValueError, match="folder name"):
        run_many([a, b], tmp_path / "o", sphere=data["sphere"], client=client)


@pytest.fixture(scope="module")
def many(data, cli):
    """Twelve targets (four shapes, noisy: every one differs) for the repeated kills."""
    shapes = ["blob", "vase", "sphere", "bowl"]
    root = data["root"] / "many"
    return [
        synth(cli, root / f"m{i:02}", shapes[i % 4], "plastic", 96, "--noise", "0.005",
              "--seed", str(10 + i))
        for i in range(12)
    ]


def test_repeated_kills_on_three_workers_lose_nothing(many, data, tmp_path):
    table = ps.calibrate(data["sphere"])
    single = {}
    for t in many:
        single[t.name] = (ps.run(t, tmp_path / "single" / t.name, sphere=table),
                          tmp_path / "single" / t.name)
    # a task may meet more than one of the kills: let the scheduler retry it
    with dask.config.set({"distributed.scheduler.allowed-failures": 10}):
        cluster = LocalCluster(n_workers=3, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
        try:
            killer = Killer(client, kills=3, gap=(0.2, 0.6), seed=1)
            killer.start()
            results = run_many(many, tmp_path / "batch", sphere=table, client=client)
            killer.done.set()
            killer.join()
        finally:
            client.close()
            cluster.close()
    print(f"killed {len(killer.killed)} workers: {killer.killed}")
    assert len(killer.killed) >= 2, f"only {len(killer.killed)} kill(s) landed"
    for r, t in zip(results, many):
        want, want_dir = single[t.name]
        assert r["dataset"] == t.name
        assert differences(r, tmp_path / "batch" / t.name, want, want_dir) == [], t.name


def test_the_memory_budget_reaches_every_run(targets, data, client, tmp_path):
    """run_many's budget is each run's: one too small for a 96² target stops the run
    before it reads a pixel, with the plan's message, and nothing is written."""
    with pytest.raises(Exception, match="memory|budget") as e:
        run_many(targets[:1], tmp_path, sphere=data["sphere"], client=client, memory="64K")
    print(f"refused: {e.value}")
    assert not (tmp_path / targets[0].name / "normals.npy").exists()
