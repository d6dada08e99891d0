#!/usr/bin/env python3
"""Time Python's Table.lookup on a second target with the same table (issue 25 item 3):
the table's lookup (search index, isolation radii, rim model) is prepared at the first
lookup and reused; a Table freshly loaded pays for it again.

Usage: scripts/py_lookup_reuse.py TABLE.lut TARGET_DIR SECOND_TARGET_DIR
(with the photostereo package importable). Prints the median of 5 runs of each, ms.
"""
import statistics
import sys
import time

import photostereo as ps


def ms(f, n=5):
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        f()
        times.append(1e3 * (time.perf_counter() - t0))
    return statistics.median(times)


def main(lut, first, second):
    a, b = ps.load_dataset(first), ps.load_dataset(second)
    for spatial in (False, True):
        fresh = ms(lambda: ps.Table.load(lut).lookup(b, spatial=spatial))
        load = ms(lambda: ps.Table.load(lut))
        table = ps.Table.load(lut)
        t0 = time.perf_counter()
        table.lookup(a, spatial=spatial)
        first_ms = 1e3 * (time.perf_counter() - t0)
        again = ms(lambda: table.lookup(b, spatial=spatial))
        print(f"spatial={spatial}: first lookup {first_ms:.1f} ms; second target, same "
              f"table {again:.1f} ms; second target, freshly loaded table {fresh:.1f} ms "
              f"(of which loading {load:.1f} ms)")


if __name__ == "__main__":
    main(*sys.argv[1:4])
