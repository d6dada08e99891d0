#!/usr/bin/env python3
"""Whole-process Frankot–Chellappa in numpy, the counterpart of
`photostereo integrate NORMALS.npy --method fc -o DEPTH.npy`: load the normal map,
compute p = -nx/nz, q = -ny/nz (n_z clamped at 0.05 as the Rust code does), integrate
with the same discretisation (numpy_integrate.fc), save float32 depth. Run by hand:

    python3 crates/photostereo/benches/numpy_fc_process.py normals.npy depth.npy
    python3 crates/photostereo/benches/numpy_fc_process.py --make normals.npy 2048

`--make` writes a 2048² sphere-cap normal map for the comparison.
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from numpy_integrate import fc  # noqa: E402


def make(path, n):
    c = np.arange(n, dtype=np.float64) + 0.5 - n / 2
    x, y = c[None, :], -c[:, None]
    rad = 0.8 * n
    z = np.sqrt(np.maximum(rad * rad - x * x - y * y, 1.0))
    x, y = np.broadcast_arrays(x, y)
    nrm = np.stack([x, y, z], -1)
    nrm /= np.linalg.norm(nrm, axis=-1, keepdims=True)
    np.save(path, nrm.astype(np.float32))


def main():
    if sys.argv[1] == "--make":
        make(sys.argv[2], int(sys.argv[3]))
        return
    n = np.load(sys.argv[1])
    nz = np.maximum(n[..., 2], 0.05)
    p = -n[..., 0] / nz
    q = -n[..., 1] / nz
    z = fc(p.astype(np.float32), q.astype(np.float32))
    np.save(sys.argv[2], (z - z.mean()).astype(np.float32))


if __name__ == "__main__":
    main()
