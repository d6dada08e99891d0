#!/usr/bin/env python3
"""Compare two recordings of scripts/bitcheck.sh byte for byte: every file equal, except
report.html (it carries the timings), and run.json compared as JSON without the seconds
(`total_seconds`, each stage's `seconds`) and without `warning_codes` (added by issue 25
item 4, so that recordings from before it compare).

Usage: scripts/bitcheck_compare.py A_DIR B_DIR   (exit status 1 when anything differs)
"""
import json
import sys
from pathlib import Path


def strip(d):
    d.pop("total_seconds", None)
    d.pop("warning_codes", None)
    d["stages"] = [s["stage"] for s in d.get("stages", [])]
    return d


def main(a, b):
    a, b = Path(a), Path(b)
    fa = sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file())
    fb = sorted(p.relative_to(b) for p in b.rglob("*") if p.is_file())
    bad = fa != fb
    if bad:
        print("file lists differ:", sorted(set(fa) ^ set(fb)))
    n = 0
    for f in sorted(set(fa) & set(fb)):
        if f.name == "report.html":
            continue
        if f.name == "run.json":
            same = strip(json.loads((a / f).read_text())) == strip(json.loads((b / f).read_text()))
        else:
            n += 1
            same = (a / f).read_bytes() == (b / f).read_bytes()
        if not same:
            print("DIFF", f)
            bad = True
    print(f"compared {n} files byte for byte (+ run.json without seconds): "
          f"{'DIFFERENT' if bad else 'identical'}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:3]))
