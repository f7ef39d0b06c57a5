"""Closure form vs exact model: an image-space accuracy sweep (layered_brdf_reference/sweep.py).

Renders, for every configuration of a seeded Latin-hypercube design, one unit sphere under
one sun with the closure form (what the shaders return) and with the exact model, and
measures the relative L1 over the highlight, the energy ratio, the mean CIEDE2000 over the
lit pixels and the holes (docs/accuracy-sweep.md).  Also the presets under a standard sun.
Writes ``benchmarks/results/accuracy_sweep.json`` and prints markdown; with ``--doc``
replaces the measured part of docs/accuracy-sweep.md (between its markers).

    .venv-5.0/bin/python benchmarks/accuracy_sweep.py --doc     # about 5 minutes on one core
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from dataclasses import asdict
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import colour  # noqa: E402
import numpy as np  # noqa: E402

from accuracy_table import _fmt  # noqa: E402  (benchmarks/ is on sys.path when the script runs)
from layered_brdf_reference import sweep  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results" / "accuracy_sweep.json"
DOC = ROOT / "docs" / "accuracy-sweep.md"
BEGIN, END = "<!-- measured: begin (benchmarks/accuracy_sweep.py --doc) -->", "<!-- measured: end -->"


def _pct(x: float) -> str:
    return f"{100.0 * x:.1f}%"


def _summary_row(label: str, s: sweep.Summary) -> str:
    return (f"| {label} | {s.configurations} | {_pct(s.l1_p50)} | {_pct(s.l1_p95)} | {_pct(s.l1_max)} | "
            f"{s.over_20} | {s.holes} ({s.configurations_with_holes}) | {s.ghosts} | {_pct(s.l1_sphere_p95)} | "
            f"{_fmt(s.energy_p5)} / {_fmt(s.energy_p50)} / "
            f"{_fmt(s.energy_p95)} | {_fmt(s.de_lit_p50)} / {_fmt(s.de_lit_p95)} |")


SUMMARY_HEAD = ["| configurations | n | L1 p50 | L1 p95 | L1 max | over 20% | holes (configs with holes) | ghosts | "
                "sphere L1 p95 | energy p5 / p50 / p95 | mean ΔE00 lit p50 / p95 |",
                "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]


def _rounded(x):
    """Floats to 6 significant digits, recursively (a smaller JSON)."""
    if isinstance(x, float):
        return float(f"{x:.6g}")
    if isinstance(x, dict):
        return {k: _rounded(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_rounded(v) for v in x]
    return x


def dumps(res: dict) -> str:
    """JSON with one configuration per line (the rows would be most of an indented file)."""
    res = _rounded(res)
    parts = []
    for k, v in res.items():
        if k in ("rgb", "spectral", "worst", "presets"):
            rows = ",\n  ".join(json.dumps(r, separators=(",", ":")) for r in v)
            parts.append(f" {json.dumps(k)}: [\n  {rows}\n ]")
        else:
            parts.append(f" {json.dumps(k)}: " + json.dumps(v, indent=1).replace("\n", "\n "))
    return "{\n" + ",\n".join(parts) + "\n}\n"


def markdown(res: dict) -> str:
    st = res["setup"]
    lines = [f"Resolution {st['resolution']} × {st['resolution']} px (sphere radius "
             f"{st['resolution'] / 2.2:.0f} px); {st['rgb_configurations']} RGB configurations (seed {st['seed']}), "
             f"{st['spectral_base']} spectral configurations (seed {st['spectral_seed']}) each in "
             f"{', '.join(st['spectral_modes'])}; {st['seconds']:.0f} s on one core "
             f"(numpy {st['numpy']}, Python {st['python']}).", "",
             "### Summary", "", *SUMMARY_HEAD]
    rgb = sweep.Summary(**res["summary"]["rgb"])
    lines.append(_summary_row("RGB design (all)", rgb))
    for key, title in (("normal_mode", "normal mode"), ("elevation", "sun elevation (°)"),
                       ("exponent", "exponents"), ("dispersion", "indices")):
        for k, s in res["summary"][key].items():
            lines.append(_summary_row(f"RGB, {title}: {k}", sweep.Summary(**s)))
    for k, s in res["summary"]["spectral"].items():
        lines.append(_summary_row(f"spectral design, {k}", sweep.Summary(**s)))
    lines += ["", "### Worst ten configurations (highest L1, both designs)", "",
              "| L1 | energy (R/G/B) | mean ΔE00 lit | holes / highlight px | configuration |",
              "| ---: | ---: | ---: | ---: | --- |"]
    for r in res["worst"]:
        m = r["metrics"]
        en = "/".join(f"{x:.2f}" for x in m["energy_rgb"])
        lines.append(f"| {_pct(m['l1'])} | {m['energy']:.2f} ({en}) | {_fmt(m['de_lit'])} | "
                     f"{m['holes']} / {m['highlight_pixels']} | {sweep.describe(r['config'])} |")
    lines += ["", f"### Presets under a standard sun ({sweep.STANDARD_SUN_DEG:g}° off the view, above it)", "",
              "A noise thickness is replaced by the height pattern over the same range (numpy does not "
              "evaluate Blender's noise).", "",
              "| preset | ks / kd | L1 over the highlight | energy | mean ΔE00 lit | holes | specular only: L1 | "
              "energy |", "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in res["presets"]:
        m, s = r["metrics"], r["specular_only"]
        lines.append(f"| {r['name']} | {r['ks']:g} / {r['kd']:g} | {_pct(m['l1'])} | {m['energy']:.3f} | "
                     f"{_fmt(m['de_lit'])} | {m['holes']} | {_pct(s['l1'])} | {s['energy']:.3f} |")
    return "\n".join(lines)


def write_doc(text: str, path: Path = DOC) -> None:
    doc = path.read_text()
    a, b = doc.index(BEGIN) + len(BEGIN), doc.index(END)
    path.write_text(doc[:a] + "\n" + text + "\n" + doc[b:])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--resolution", type=int, default=160, help="image width and height in pixels")
    ap.add_argument("--configurations", type=int, default=2400, help="size of the RGB design")
    ap.add_argument("--spectral", type=int, default=40, help="size of the spectral design (x every mode)")
    ap.add_argument("--seed", type=int, default=2003)
    ap.add_argument("--spectral-seed", type=int, default=2004)
    ap.add_argument("--out", type=Path, default=RESULTS)
    ap.add_argument("--doc", action="store_true", help="rewrite the measured part of docs/accuracy-sweep.md")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()

    def progress(k, c, m):
        if (k + 1) % 200 == 0:
            print(f"  {k + 1} configurations, {time.perf_counter() - t0:.0f} s", file=sys.stderr)

    rgb = sweep.run(sweep.design(args.configurations, args.seed), args.resolution, progress=progress)
    spectral = sweep.run(sweep.spectral_design(args.spectral, args.spectral_seed), args.resolution, progress=progress)
    presets = sweep.preset_rows(args.resolution)
    seconds = time.perf_counter() - t0

    def by(key):
        return {k: asdict(v) for k, v in sweep.groups(rgb, key).items()}

    summary = dict(
        rgb={k: v for k, v in asdict(sweep.summarise(rgb)).items() if k != "worst"},
        normal_mode=by(lambda c: c["normal_mode"]), elevation=by(sweep.elevation_band),
        exponent=by(sweep.exponent_band),
        dispersion=by(lambda c: "dispersive" if c["dispersive"] else "equal"),
        spectral={k: asdict(v) for k, v in sweep.groups(spectral, lambda c: c["accuracy"]).items()})
    res = dict(
        setup=dict(resolution=args.resolution, rgb_configurations=len(rgb), seed=args.seed,
                   spectral_base=args.spectral, spectral_seed=args.spectral_seed,
                   spectral_modes=list(sweep.ACCURACY_MODES), seconds=seconds,
                   highlight_fraction=sweep.HIGHLIGHT_FRACTION, hole_fraction=sweep.HOLE_FRACTION,
                   standard_sun_deg=sweep.STANDARD_SUN_DEG, numpy=np.__version__, colour=colour.__version__,
                   python=platform.python_version()),
        summary=summary, worst=sweep.summarise(rgb + spectral).worst, presets=presets, rgb=rgb, spectral=spectral)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(dumps(res))
    text = markdown(res)
    print(text)
    if args.doc:
        write_doc(text)
    print(f"\nwrote {args.out} in {seconds:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
