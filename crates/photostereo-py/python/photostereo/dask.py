"""Batch runs on a Dask cluster: one ``photostereo.run`` per target.

    from photostereo.dask import run_many
    results = run_many(["scans/part1", "scans/part2"], "out", sphere="scans/sphere")

The calibration table is built once (here) and shipped to every worker; each target's
outputs go to ``out/<target's folder name>/``; the results are what single-process
``photostereo.run(target, out/<name>, sphere=...)`` gives. A worker that dies mid-run is
survived: Dask runs its task again elsewhere, and no half-written file is left (every
file is written to a temporary name and renamed when complete). Each run keeps within
its worker's memory: the worker's limit shared among its threads (one target per thread
at a time) is the run's ``memory`` budget, so the images are read by bands that fit it.

From the shell (``pip install ./crates/photostereo-py[dask]``)::

    python -m photostereo.dask --sphere SPHERE TARGET... -o OUT [--scheduler tcp://HOST:8786]
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import Any, Optional, Sequence, Union

from . import Table, calibrate
from . import run as _run

PathLike = Union[str, "os.PathLike[str]"]


def _run_one(target: str, out: str, table: Optional[Table], options: dict) -> dict:
    """One target on a worker (a module-level function: workers import it by name).

    A worker killed while writing leaves a temporary file (``.NAME.tmp-PID-N``, never a
    half-written output); the task's re-run removes them first."""
    if os.path.isdir(out):
        for name in os.listdir(out):
            if name.startswith(".") and ".tmp-" in name:
                try:
                    os.remove(os.path.join(out, name))
                except OSError:
                    pass
    if table is not None:
        return _run(target, out, sphere=table, **options)
    return _run(target, out, **options)


def _identity(x: Any) -> Any:
    """The calibration table as a task's result (see :func:`run_many`)."""
    return x


def _task_budget(client: Any) -> Optional[int]:
    """Bytes one task may use: the smallest worker memory limit divided by that worker's
    threads (tasks run one per thread); None when a worker has no limit."""
    workers = client.scheduler_info().get("workers", {}).values()
    budgets = [
        int(w["memory_limit"]) // max(int(w.get("nthreads", 1)), 1)
        for w in workers
        if w.get("memory_limit")
    ]
    return min(budgets) if budgets and len(budgets) == len(workers) else None


def _out_dirs(targets: Sequence[PathLike], out: PathLike) -> list[str]:
    names = [Path(os.fspath(t)).resolve().name for t in targets]
    seen: dict[str, str] = {}
    for t, n in zip(targets, names):
        if n in seen:
            raise ValueError(
                f"targets {seen[n]} and {os.fspath(t)} share the folder name '{n}': "
                "their outputs would both go to out/{n}; rename one of them"
            )
        seen[n] = os.fspath(t)
    return [os.path.join(os.fspath(out), n) for n in names]


def run_many(
    targets: Sequence[PathLike],
    out: PathLike,
    *,
    sphere: Union[PathLike, Table, None] = None,
    client: Any = None,
    memory: Union[int, str, None] = None,
    **options: Any,
) -> list:
    """Run ``photostereo.run`` on every target on a Dask cluster; returns the run.json
    dicts in the order of ``targets``.

    targets: dataset directories; out: output directory, one sub-directory per target
        (its folder name).
    sphere: calibration sphere directory or a Table: the table is built once, here,
        and shipped to the workers. None for Lambertian runs (``lambertian=True``).
    client: a ``dask.distributed.Client``; None starts a LocalCluster (one worker
        process per core, one thread each, the machine's memory shared among them) for
        this call.
    memory: each run's memory budget (bytes or "2G"); default: its worker's memory
        limit divided by the worker's threads (the run's own default where workers have
        no limit).
    options: the keyword options of :func:`photostereo.run` (lambertian, lights,
        chrome, interreflections, image_scale, method, mask).

    Raises ImportError when dask.distributed is missing (``pip install photostereo[dask]``).
    """
    from dask.distributed import Client, LocalCluster

    targets = [os.fspath(t) for t in targets]
    dirs = _out_dirs(targets, out)
    table = sphere
    if sphere is not None and not isinstance(sphere, Table):
        table = calibrate(sphere)
    own = client is None
    cluster = None
    if own:
        cluster = LocalCluster(
            n_workers=os.cpu_count() or 1, threads_per_worker=1, processes=True
        )
        client = Client(cluster)
    try:
        budget = memory if memory is not None else _task_budget(client)
        if budget is not None:
            options = {**options, "memory": budget}
        shipped = None
        if table is not None:
            # a task, not `scatter`: scattered data has no recipe, so once every worker
            # holding it is killed the runs that need it are cancelled; a task's result
            # is computed again from the table the scheduler keeps
            shipped = client.submit(_identity, table, pure=False)
        futures = [
            client.submit(_run_one, t, d, shipped, dict(options), pure=False)
            for t, d in zip(targets, dirs)
        ]
        return client.gather(futures)
    finally:
        if own:
            client.close()
            cluster.close()


def main(argv: Optional[Sequence[str]] = None) -> int:
    """``python -m photostereo.dask``: run_many from the shell, results printed as JSON lines."""
    import json

    p = argparse.ArgumentParser(
        prog="python -m photostereo.dask",
        description="photostereo run on many targets on a Dask cluster",
        epilog="Example: python -m photostereo.dask --sphere data/sphere data/part* -o out",
    )
    p.add_argument("targets", nargs="+", help="target dataset directories")
    p.add_argument("-o", "--out", required=True, help="output directory (one folder per target)")
    p.add_argument("--sphere", help="calibration sphere directory (calibration-based)")
    p.add_argument("--lambertian", action="store_true", help="Lambertian with known lights")
    p.add_argument("--method", help="integrator: path, fc, fc-reflect, dct, lsq")
    p.add_argument("--scheduler", help="scheduler address, e.g. tcp://HOST:8786 (default: a local cluster)")
    a = p.parse_args(argv)
    client = None
    if a.scheduler:
        from dask.distributed import Client

        client = Client(a.scheduler)
    opts: dict = {}
    if a.lambertian:
        opts["lambertian"] = True
    if a.method:
        opts["method"] = a.method
    try:
        results = run_many(a.targets, a.out, sphere=a.sphere, client=client, **opts)
    except (OSError, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    for t, r in zip(a.targets, results):
        print(json.dumps({"target": t, **r}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
