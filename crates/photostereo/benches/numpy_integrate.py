#!/usr/bin/env python3
"""numpy/scipy versions of the Fourier integrators, timed side by side with
`photostereo bench` (run by hand; not part of CI).

    pip install numpy scipy
    python3 crates/photostereo/benches/numpy_integrate.py [--size 2048] [--repeat 3]
    cargo run --release -p photostereo-cli -- bench --only fft-floor,fc,dct

Same discretisation as the Rust code (trapezoidal edge targets, periodic Laplacian
for FC, Neumann Laplacian for DCT), float32 like the Rust kernels.
"""
import argparse
import time

import numpy as np
import scipy.fft


def sphere_gradients(n):
    c = np.arange(n, dtype=np.float64) + 0.5 - n / 2
    x = c[None, :]
    y = -c[:, None]
    rad = 0.8 * n
    z = np.sqrt(np.maximum(rad * rad - x * x - y * y, 1.0))
    return (-x / z).astype(np.float32), (-y / z).astype(np.float32)


def fft_floor(img):
    return np.fft.irfft2(np.fft.rfft2(img), s=img.shape)


def fc(p, q):
    h, w = p.shape
    div = 0.5 * (np.roll(p, -1, 1) - np.roll(p, 1, 1)) - 0.5 * (np.roll(q, -1, 0) - np.roll(q, 1, 0))
    spec = np.fft.rfft2(div.astype(np.float32))
    kc = 2 * np.cos(2 * np.pi * np.arange(w // 2 + 1) / w)
    kr = 2 * np.cos(2 * np.pi * np.arange(h) / h)
    lam = (kc[None, :] + kr[:, None] - 4).astype(np.float32)
    lam[0, 0] = 1
    spec /= lam
    spec[0, 0] = 0
    return np.fft.irfft2(spec, s=(h, w))


def dct(p, q):
    h, w = p.shape
    gx = 0.5 * (p[:, :-1] + p[:, 1:])
    gy = -0.5 * (q[:-1, :] + q[1:, :])
    b = np.zeros_like(p)
    b[:, :-1] += gx
    b[:, 1:] -= gx
    b[:-1, :] += gy
    b[1:, :] -= gy
    spec = scipy.fft.dctn(b, type=2)
    kc = 2 * np.cos(np.pi * np.arange(w) / w)
    kr = 2 * np.cos(np.pi * np.arange(h) / h)
    lam = (kc[None, :] + kr[:, None] - 4).astype(np.float32)
    lam[0, 0] = 1
    spec /= lam
    spec[0, 0] = 0
    return scipy.fft.idctn(spec, type=2)


def best(f, repeat):
    """Fastest wall time and mean CPU time per run (process_time: all threads)."""
    f()
    times = []
    c0 = time.process_time()
    for _ in range(repeat):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return min(times), (time.process_time() - c0) / repeat


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=2048)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    p, q = sphere_gradients(a.size)
    print(f"numpy {np.__version__}, scipy {scipy.__version__}, {a.size}x{a.size} float32")
    print(f"{'row':<12} {'best s':>10} {'cpu s/run':>10}")
    for name, f in [
        ("fft-floor", lambda: fft_floor(p)),
        ("fc", lambda: fc(p, q)),
        ("dct", lambda: dct(p, q)),
    ]:
        wall, cpu = best(f, a.repeat)
        print(f"{name:<12} {wall:>10.4f} {cpu:>10.4f}")


if __name__ == "__main__":
    main()
