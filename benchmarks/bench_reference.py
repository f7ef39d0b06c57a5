"""Throughput of the numpy reference: BRDF evaluations per second (3 channels, one core).

Prints a table; ratios and figures are from this run only.
"""
from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from layered_brdf_addon.model.params import LayeredParams  # noqa: E402
from layered_brdf_reference.exact_model import layered_brdf, specular_brdf  # noqa: E402


def random_unit(rng, n, up=False):
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    if up:
        v[:, 2] = np.abs(v[:, 2])
    return v


def run(n: int, chunk: int, repeats: int) -> list[tuple[str, float]]:
    rng = np.random.default_rng(1)
    i = -random_unit(rng, n, up=True)
    o = random_unit(rng, n, up=True)
    n0 = random_unit(rng, n) * 0.2 + [0, 0, 1]
    n1 = n0 + 0.1 * random_unit(rng, n)
    d = rng.uniform(0, 1000, n)
    p = LayeredParams()
    z = np.array([0.0, 0.0, 1.0])
    cases = {
        "specular, per-sample n0 and n1": lambda s: specular_brdf(i[s], o[s], n0[s], n1[s], p.r1, d[s], p.e0, p.e1),
        "specular, fixed parallel normals": lambda s: specular_brdf(i[s], o[s], z, z, p.r1, d[s], p.e0, p.e1),
        "full BRDF (specular + diffuse)": lambda s: layered_brdf(i[s], o[s], n0[s], n1[s], d[s], p),
    }
    rows = []
    for name, fn in cases.items():
        best = np.inf
        for _ in range(repeats):
            t0 = time.perf_counter()
            for start in range(0, n, chunk):
                fn(slice(start, start + chunk))
            best = min(best, time.perf_counter() - t0)
        rows.append((name, n / best))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("-n", type=int, default=1_000_000, help="direction pairs")
    ap.add_argument("--chunk", type=int, default=8192, help="pairs per vectorised call")
    ap.add_argument("--repeats", type=int, default=3, help="best of this many runs")
    args = ap.parse_args(argv)
    rows = run(args.n, args.chunk, args.repeats)
    print(f"numpy {np.__version__}, {args.n:,} random direction pairs, chunks of {args.chunk}, best of {args.repeats}")
    print(f"{'case':<36} {'evaluations/s':>15}")
    for name, rate in rows:
        print(f"{name:<36} {rate:>15,.0f}")


if __name__ == "__main__":
    main()
