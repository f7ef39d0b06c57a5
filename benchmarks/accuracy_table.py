"""Colour accuracy of the RGB and spectral modes against the 1 nm spectral ground truth.

For every mode (the paper's three wavelengths used directly as linear Rec.709 channels;
``N`` = 4, 8, 16, 32 spectral samples; the Wyman analytic CMFs; the closure forms) this
measures the CIEDE2000 difference to the 1 nm ground truth over a fixed sweep of
thickness, view angle, lower-normal tilt and the index triples of the presets, and the
numpy throughput on one core.  Prints markdown tables and writes
``benchmarks/results/accuracy.json``.  All numbers are from this run.

Sweep: thickness 0-1000 nm (41 values), view angles 0-85 degrees (8), tilt 0, 10, 14
degrees (the lower normal turned within the plane of incidence, towards the viewer), the
distinct ``r1`` triples of :data:`PRESETS`, ``e0 = e1 = 130``, ``r0 = 1``.  The specular
part is evaluated at the highlight: for tilt 0 the light is at the mirror direction of
the view; for a tilt it is at the peak of the green channel's transmitted lobe (the light
direction whose path through the layer leaves along the view), falling back to the
mirror direction where no such path exists.  Specular values are divided by
``(e0 + 2) / (2 pi)``, so they read as reflectances (about 0-1.5).  The diffuse part is
``rho_d`` (eq. 18), which depends on thickness and indices only.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import colour  # noqa: E402
import numpy as np  # noqa: E402

from layered_brdf_addon.model.geometry import dot, reflect, refract  # noqa: E402
from layered_brdf_addon.model.params import WAVELENGTHS_NM, LayeredParams  # noqa: E402
from layered_brdf_addon.model.presets import PRESETS  # noqa: E402
from layered_brdf_reference import spectral  # noqa: E402
from layered_brdf_reference.closures import closure_shading, single_lobe_shading  # noqa: E402
from layered_brdf_reference.exact_model import diffuse_rho, specular_brdf  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "accuracy.json"
E0 = 130.0
E1 = 130.0
R0 = 1.0
DISPERSIVE = (1.5, 1.6, 1.8)


def preset_index_triples() -> list[tuple[float, float, float]]:
    """The distinct ``(r1_r, r1_g, r1_b)`` of the presets, in preset order."""
    base = LayeredParams()
    out: list[tuple[float, float, float]] = []
    for overrides in PRESETS.values():
        t = LayeredParams.from_dict(overrides, base=base).r1
        if t not in out:
            out.append(t)
    return out


def transmitted_peak_light(o: np.ndarray, n0: np.ndarray, n1: np.ndarray, r1: float, r0: float = R0):
    """Direction to the light (unit, (P, 3)) whose path refracts into the layer at ``n0``,
    mirrors on ``n1`` and leaves along ``o``; and whether that path exists."""
    t_o, ok_in = refract(-o, n0, r0 / r1)  # in-layer direction that leaves as o, reversed
    to_n1 = dot(t_o, n1)
    r = reflect(t_o, n1)  # towards the upper boundary, from below
    l, ok_out = refract(r, -n0, r1 / r0)
    ok = ok_in & ok_out & (to_n1 < 0.0) & (dot(r, n0) > 0.0) & (dot(l, n0) > 0.0)
    return l, ok


def sweep(n_thickness: int = 41, n_view: int = 8, tilts=(0.0, 10.0, 14.0)) -> dict:
    """The configurations of the sweep, flattened: per index triple, arrays over (tilt, view, d)."""
    d = np.linspace(0.0, 1000.0, n_thickness)
    views = np.linspace(0.0, 85.0, n_view)
    tilt, view, dd = np.meshgrid(np.asarray(tilts, dtype=float), views, d, indexing="ij")
    tilt, view, dd = tilt.ravel(), view.ravel(), dd.ravel()
    th = np.radians(view)
    o = np.stack([np.sin(th), np.zeros_like(th), np.cos(th)], axis=-1)
    n0 = np.broadcast_to([0.0, 0.0, 1.0], o.shape).copy()
    tau = np.radians(tilt)
    n1 = np.stack([np.sin(tau), np.zeros_like(tau), np.cos(tau)], axis=-1)
    mirror = np.stack([-o[:, 0], o[:, 1], o[:, 2]], axis=-1)
    return dict(d=d, views=views, tilts=np.asarray(tilts, dtype=float), tilt=tilt, view=view, dd=dd, o=o, n0=n0,
                n1=n1, mirror=mirror)


def light_directions(sw: dict, r1: tuple[float, float, float]) -> tuple[np.ndarray, float]:
    """Highlight light directions of the sweep for one triple, and the share of tilted
    configurations that fell back to the mirror direction."""
    l_star, ok = transmitted_peak_light(sw["o"], sw["n0"], sw["n1"], r1[1])
    tilted = sw["tilt"] != 0.0
    use = tilted & ok
    l = np.where(use[:, None], l_star, sw["mirror"])
    fallback = float(np.mean(~ok[tilted])) if np.any(tilted) else 0.0
    return l, fallback


ANALYTIC = "analytic"  # the analytic mode: three channels, interference integrated over each band


def modes() -> dict[str, spectral.SpectralSampling | str | None]:
    """The evaluated modes; ``None`` is the RGB mode (three wavelengths used as channels),
    :data:`ANALYTIC` the analytic mode (model/spectral_band.py)."""
    out: dict[str, spectral.SpectralSampling | str | None] = {"RGB (645/525/445 nm)": None,
                                                              "analytic (closed-form band)": ANALYTIC}
    for n in spectral.SAMPLE_COUNTS:
        out[f"spectral {n}"] = spectral.spectral_sampling(n)
    out["spectral 32, point-sampled"] = spectral.spectral_sampling(32, "cie1931", "point")
    out["spectral 32, Wyman CMF"] = spectral.spectral_sampling(32, "wyman")
    out["spectral 32, Wyman CMF, point-sampled"] = spectral.spectral_sampling(32, "wyman", "point")
    out["1 nm, Wyman CMF"] = spectral.ground_truth_sampling("wyman")
    return out


def specular_rgb(mode: spectral.SpectralSampling | str | None, i, o, n0, n1, r1, d) -> np.ndarray:
    norm = (E0 + 2.0) / (2.0 * np.pi)
    if mode is None or mode == ANALYTIC:
        return specular_brdf(i, o, n0, n1, r1, d, E0, E1, R0, WAVELENGTHS_NM, n0, band=mode == ANALYTIC) / norm
    return spectral.spectral_specular(i, o, n0, n1, r1, d, E0, E1, R0, mode, n0) / norm


def diffuse_rgb(mode: spectral.SpectralSampling | str | None, r1, d) -> np.ndarray:
    if mode is None or mode == ANALYTIC:
        return diffuse_rho(r1, d, R0, WAVELENGTHS_NM, band=mode == ANALYTIC)
    return spectral.spectral_diffuse(r1, d, R0, mode)


def stats(de: np.ndarray, rgb_diff: np.ndarray | None = None) -> dict:
    out = dict(mean=float(np.mean(de)), p95=float(np.percentile(de, 95)), max=float(np.max(de)))
    if rgb_diff is not None:
        out["max_rgb_diff"] = float(np.max(rgb_diff))
    return out


def closure_params(r1, tilt: float, lobe: str, accuracy: str = "rgb") -> LayeredParams:
    return LayeredParams.from_dict(dict(r1_r=r1[0], r1_g=r1[1], r1_b=r1[2], e0=E0, e1=E1, ks=1.0, kd=0.0, r0=R0,
                                        normal_mode="tilted" if tilt else "parallel", tilt=tilt, lobe=lobe,
                                        d_min=0.0, d_max=1000.0, accuracy=accuracy))


def closure_rgb(kind: str, r1, sw: dict, l: np.ndarray) -> np.ndarray:
    """Pixel per unit irradiance of a closure level, divided by ``<l, n0> (e0 + 2)/(2 pi)``."""
    out = np.empty((sw["dd"].shape[0], 3))
    norm = (E0 + 2.0) / (2.0 * np.pi)
    for tilt in sw["tilts"]:
        sel = sw["tilt"] == tilt
        n0, n1, o, ll, d = sw["n0"][sel], sw["n1"][sel], sw["o"][sel], l[sel], sw["dd"][sel]
        if kind == "single lobe":
            pix = single_lobe_shading(closure_params(r1, tilt, "phong"), n0, n1, d, ll, o)
        else:
            lobe, _, acc = kind.partition(":")
            pix = closure_shading(closure_params(r1, tilt, lobe, acc or "rgb"), n0, n1, d, ll, o, ng=n0)
        out[sel] = pix / (dot(n0, ll) * norm)[:, None]
    return out


def accuracy(sw: dict) -> dict:
    triples = preset_index_triples()
    gt = spectral.ground_truth_sampling()
    mode_map = modes()
    spec_de = {m: [] for m in mode_map}
    spec_diff = {m: [] for m in mode_map}
    diff_de = {m: [] for m in mode_map}
    diff_diff = {m: [] for m in mode_map}
    closure_kinds = {"closure form (beckmann)": "beckmann", "closure form (phong)": "phong",
                     "single lobe": "single lobe", "closure form (beckmann), analytic": "beckmann:analytic",
                     **{f"closure form (beckmann), spectral {n}": f"beckmann:spectral{n}" for n in (4, 8, 16, 32)}}
    clo_de = {k: [] for k in closure_kinds}
    clo_de_rgb = {k: [] for k in closure_kinds}
    clo_tilted = []
    per_triple: dict[str, dict] = {}
    fallbacks = {}
    min_rgb = {m: np.inf for m in mode_map}
    min_rgb["ground truth"] = np.inf
    for r1 in triples:
        key = "/".join(f"{x:g}" for x in r1)
        l, fb = light_directions(sw, r1)
        fallbacks[key] = fb
        i = -l
        ref = specular_rgb(gt, i, sw["o"], sw["n0"], sw["n1"], r1, sw["dd"])
        ref_d = diffuse_rgb(gt, r1, sw["d"])
        min_rgb["ground truth"] = min(min_rgb["ground truth"], float(ref.min()), float(ref_d.min()))
        per_triple[key] = {}
        rgb_exact = None
        for name, mode in mode_map.items():
            val = specular_rgb(mode, i, sw["o"], sw["n0"], sw["n1"], r1, sw["dd"])
            de = spectral.delta_e_2000(val, ref)
            spec_de[name].append(de)
            spec_diff[name].append(np.abs(val - ref).max(axis=-1))
            vd = diffuse_rgb(mode, r1, sw["d"])
            dde = spectral.delta_e_2000(vd, ref_d)
            diff_de[name].append(dde)
            diff_diff[name].append(np.abs(vd - ref_d).max(axis=-1))
            min_rgb[name] = min(min_rgb[name], float(val.min()), float(vd.min()))
            per_triple[key][name] = dict(specular_mean=float(de.mean()), specular_p95=float(np.percentile(de, 95)),
                                         diffuse_mean=float(dde.mean()), diffuse_p95=float(np.percentile(dde, 95)))
            if mode is None:
                rgb_exact = val
        for label, kind in closure_kinds.items():
            val = closure_rgb(kind, r1, sw, l)
            clo_de[label].append(spectral.delta_e_2000(val, ref))
            clo_de_rgb[label].append(spectral.delta_e_2000(val, rgb_exact))
        clo_tilted.append(sw["tilt"] != 0.0)
    cat = np.concatenate
    tilted = cat(clo_tilted)

    def split(de: np.ndarray) -> dict:
        return dict(all=stats(de), tilt_0=stats(de[~tilted]), tilted=stats(de[tilted]))

    tilted_all = np.tile(sw["tilt"] != 0.0, len(triples))
    result = dict(
        modes={m: dict(specular=stats(cat(spec_de[m]), cat(spec_diff[m])),
                       specular_tilt_0=stats(cat(spec_de[m])[~tilted_all]),
                       diffuse=stats(cat(diff_de[m]), cat(diff_diff[m])),
                       min_rgb=min_rgb[m]) for m in mode_map},
        closure_levels={k: dict(vs_ground_truth=split(cat(clo_de[k])), vs_rgb_exact=split(cat(clo_de_rgb[k])))
                        for k in closure_kinds},
        rgb_exact_by_tilt=split(cat(spec_de["RGB (645/525/445 nm)"])),
        per_triple=per_triple,
        tilted_mirror_fallback=fallbacks,
        ground_truth_min_rgb=min_rgb["ground truth"],
        triples=[list(t) for t in triples],
    )
    return result


def throughput(points: int = 4096, repeats: int = 5) -> dict:
    """Specular and diffuse evaluations (one RGB result each) per second, one core."""
    rng = np.random.default_rng(7)
    th_o = rng.uniform(0.0, np.radians(85.0), points)
    ph = rng.uniform(0.0, 2.0 * np.pi, points)
    o = np.stack([np.sin(th_o) * np.cos(ph), np.sin(th_o) * np.sin(ph), np.cos(th_o)], axis=-1)
    n0 = np.broadcast_to([0.0, 0.0, 1.0], o.shape).copy()
    n1 = np.broadcast_to([np.sin(np.radians(10.0)), 0.0, np.cos(np.radians(10.0))], o.shape).copy()
    l = np.stack([-o[:, 0], -o[:, 1], o[:, 2]], axis=-1)
    i = -l
    d = rng.uniform(0.0, 1000.0, points)
    r1 = DISPERSIVE

    def best(fn) -> float:
        t = np.inf
        for _ in range(repeats):
            t0 = time.perf_counter()
            fn()
            t = min(t, time.perf_counter() - t0)
        return points / t

    out = {}
    gt = spectral.ground_truth_sampling()
    for name, mode in {**modes(), "ground truth 1 nm": gt}.items():
        out[name] = dict(specular=best(lambda: specular_rgb(mode, i, o, n0, n1, r1, d)),
                         diffuse=best(lambda: diffuse_rgb(mode, r1, d)))
    p_b = closure_params(r1, 10.0, "beckmann")
    p_p = closure_params(r1, 10.0, "phong")
    out["closure form (beckmann)"] = dict(specular=best(lambda: closure_shading(p_b, n0, n1, d, l, o, ng=n0)))
    out["closure form (phong)"] = dict(specular=best(lambda: closure_shading(p_p, n0, n1, d, l, o, ng=n0)))
    out["single lobe"] = dict(specular=best(lambda: single_lobe_shading(p_p, n0, n1, d, l, o)))
    return out


def cutoffs() -> dict:
    """Thickness beyond which interference changes the colour by less than a tolerance."""
    rows = []
    for r1 in (1.33, 1.5, 2.0, 2.3):
        td = float(80.0 * r1 / (21.0 * (r1 + 1.0) ** 2))
        m_diffuse = 2.0 * np.sqrt(td * (1.0 - td))
        row = dict(r1=r1, diffuse_modulation=m_diffuse)
        for tol in (0.5, 1.0, 2.0):
            d_star = spectral.interference_cutoff_nm(r1, tol)
            row[f"d_star_tol{tol:g}"] = d_star
            row[f"periods_tol{tol:g}"] = float(spectral.phase_spread(r1, d_star) / (2.0 * np.pi))
        row["d_star_diffuse_tol1"] = spectral.interference_cutoff_nm(r1, 1.0, modulation=m_diffuse)
        rows.append(row)
    return dict(rows=rows, optical_tol1=spectral.interference_cutoff_optical_nm(1.0),
                optical_tol1_wyman=spectral.interference_cutoff_optical_nm(1.0, cmf="wyman"))


def thick_layers(r1=(1.5, 1.5, 1.5), bands=((1000.0, 2000.0), (2000.0, 3000.0), (3000.0, 4000.0), (4000.0, 6000.0)),
                 step: float = 2.0) -> dict:
    """Diffuse ``rho_d`` of thick layers: CIEDE2000 to the ground truth of the spectral modes and
    of the interference-free mean (``rho_d = 1``, what a planner would use beyond ``d*``)."""
    gt = spectral.ground_truth_sampling()
    out = {}
    for lo, hi in bands:
        d = np.arange(lo, hi, step)
        ref = diffuse_rgb(gt, r1, d)
        row = {}
        for n in (16, 32):
            de = spectral.delta_e_2000(diffuse_rgb(spectral.spectral_sampling(n), r1, d), ref)
            row[f"spectral {n}"] = dict(mean=float(de.mean()), max=float(de.max()))
        de = spectral.delta_e_2000(diffuse_rgb(ANALYTIC, r1, d), ref)
        row["analytic"] = dict(mean=float(de.mean()), max=float(de.max()))
        de = spectral.delta_e_2000(np.ones_like(ref), ref)
        row["mean colour"] = dict(mean=float(de.mean()), max=float(de.max()))
        out[f"{lo:g}-{hi:g}"] = row
    return dict(r1=list(r1), bands=out)


def _fmt(x: float) -> str:
    if not np.isfinite(x):
        return "inf"
    if x >= 1e5:
        return f"{x:.3g}"
    if x >= 100:
        return f"{x:.0f}"
    if x >= 10:
        return f"{x:.1f}"
    return f"{x:.2f}" if x >= 0.1 else f"{x:.3f}"


def markdown(res: dict) -> str:
    acc, tp = res["accuracy"], res["throughput"]
    lines = ["### CIEDE2000 to the 1 nm spectral ground truth", "",
             "| mode | specular mean | specular p95 | specular max | specular, tilt 0: mean / p95 | diffuse mean "
             "| diffuse p95 | diffuse max | max RGB diff (spec / diff) | specular evals/s | diffuse evals/s |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for name, m in acc["modes"].items():
        s, d, s0 = m["specular"], m["diffuse"], m["specular_tilt_0"]
        t = tp[name]
        lines.append(f"| {name} | {_fmt(s['mean'])} | {_fmt(s['p95'])} | {_fmt(s['max'])} | "
                     f"{_fmt(s0['mean'])} / {_fmt(s0['p95'])} | {_fmt(d['mean'])} | "
                     f"{_fmt(d['p95'])} | {_fmt(d['max'])} | {s['max_rgb_diff']:.3f} / {d['max_rgb_diff']:.3f} | "
                     f"{t['specular']:.3g} | {t['diffuse']:.3g} |")
    gt = tp["ground truth 1 nm"]
    lines.append(f"| ground truth 1 nm | 0 | 0 | 0 | 0 | 0 | 0 | 0 | 0 | {gt['specular']:.3g} | {gt['diffuse']:.3g} |")
    lines += ["", "### Closure approximation levels (RGB mode, specular, pixel per unit irradiance)", "",
              "Mean / p95 CIEDE2000; columns: all configurations, tilt 0 only, tilt 10 and 14 only.", "",
              "| level | vs ground truth: all | tilt 0 | tilted | vs RGB exact: all | tilt 0 | tilted | evals/s |",
              "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]

    def mp(s: dict) -> str:
        return f"{_fmt(s['mean'])} / {_fmt(s['p95'])}"

    ex = acc["rgb_exact_by_tilt"]
    lines.append(f"| exact model (RGB) | {mp(ex['all'])} | {mp(ex['tilt_0'])} | {mp(ex['tilted'])} | 0 | 0 | 0 | "
                 f"{tp['RGB (645/525/445 nm)']['specular']:.3g} |")
    for k, v in acc["closure_levels"].items():
        g, r = v["vs_ground_truth"], v["vs_rgb_exact"]
        lines.append(f"| {k} | {mp(g['all'])} | {mp(g['tilt_0'])} | {mp(g['tilted'])} | {mp(r['all'])} | "
                     f"{mp(r['tilt_0'])} | {mp(r['tilted'])} | {tp.get(k, {}).get('specular', float('nan')):.3g} |")
    names = list(acc["modes"])
    lines += ["", "### Mean specular / diffuse CIEDE2000 per index triple", "",
              "| r1 (R/G/B) | " + " | ".join(names) + " |", "| --- |" + " ---: |" * len(names)]
    for key, row in acc["per_triple"].items():
        lines.append(f"| {key} | " + " | ".join(f"{_fmt(row[n]['specular_mean'])} / {_fmt(row[n]['diffuse_mean'])}"
                                                for n in names) + " |")
    c = res["cutoffs"]
    lines += ["", "### Interference cut-off d* (nm): colour within tolerance of the interference-free mean "
              "beyond it (modulation 1, level 1)", "",
              "| r1 | d* (ΔE 0.5) | d* (ΔE 1) | d* (ΔE 2) | diffuse modulation | d* diffuse (ΔE 1) |",
              "| ---: | ---: | ---: | ---: | ---: | ---: |"]
    for row in c["rows"]:
        lines.append(f"| {row['r1']:g} | {_fmt(row['d_star_tol0.5'])} | {_fmt(row['d_star_tol1'])} | "
                     f"{_fmt(row['d_star_tol2'])} | {row['diffuse_modulation']:.3f} | "
                     f"{_fmt(row['d_star_diffuse_tol1'])} |")
    tl = res["thick_layers"]
    lines += ["", f"### Thick layers, diffuse, r1 = {'/'.join(f'{x:g}' for x in tl['r1'])}: mean / max CIEDE2000 "
              "to the ground truth", "", "| d (nm) | spectral 16 | spectral 32 | analytic | interference dropped (mean colour) |",
              "| --- | ---: | ---: | ---: | ---: |"]
    for band, row in tl["bands"].items():
        lines.append(f"| {band} | " + " | ".join(f"{_fmt(row[k]['mean'])} / {_fmt(row[k]['max'])}"
                                                 for k in ("spectral 16", "spectral 32", "analytic", "mean colour"))
                     + " |")
    periods = {f"{t:g}": c["rows"][0][f"periods_tol{t:g}"] for t in (0.5, 1.0, 2.0)}
    lines += ["", f"Optical thickness cut-off r1·d* (ΔE 1): {c['optical_tol1']:g} nm "
              f"(with the Wyman CMFs: {c['optical_tol1_wyman']:g} nm); phase spread across 380-780 nm at d*, "
              f"in periods, for ΔE 0.5 / 1 / 2: " + " / ".join(f"{v:.2f}" for v in periods.values()) + "."]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--thickness", type=int, default=41, help="thickness samples over 0-1000 nm")
    ap.add_argument("--views", type=int, default=8, help="view angles over 0-85 degrees")
    ap.add_argument("--points", type=int, default=4096, help="batch size of the throughput timing")
    ap.add_argument("--out", type=Path, default=RESULTS)
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    sw = sweep(args.thickness, args.views)
    res = dict(accuracy=accuracy(sw), throughput=throughput(args.points), cutoffs=cutoffs(),
               thick_layers=thick_layers())
    res["white_correction"] = {s.label: s.white_correction.tolist() for s in
                               (spectral.ground_truth_sampling(), spectral.spectral_sampling(32, "cie1931", "point"),
                                spectral.ground_truth_sampling("wyman"), spectral.spectral_sampling(32, "wyman"),
                                spectral.spectral_sampling(32, "wyman", "point"))}
    res["wyman_table_error"] = spectral.wyman_table_error()
    res["setup"] = dict(thickness_nm=sw["d"].tolist(), view_deg=sw["views"].tolist(), tilt_deg=sw["tilts"].tolist(),
                        e0=E0, e1=E1, r0=R0, configurations_per_triple=int(sw["dd"].shape[0]),
                        light="mirror for tilt 0; green transmitted-lobe peak for tilt != 0 (mirror if no path)",
                        numpy=np.__version__, colour=colour.__version__, python=platform.python_version(),
                        seconds=None)
    res["setup"]["seconds"] = time.perf_counter() - t0
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(res, indent=2))
    print(markdown(res))
    print(f"\nwhite correction (diag, ground truth / all N with CIE tables): {res['white_correction']}")
    print(f"Wyman CMF vs CIE 1931 table: {res['wyman_table_error']}")
    print("tilted configurations without a transmitted path (mirror used): "
          f"{res['accuracy']['tilted_mirror_fallback']}")
    print(f"lowest RGB value per mode: { {k: round(v['min_rgb'], 4) for k, v in res['accuracy']['modes'].items()} }"
          f"; ground truth {res['accuracy']['ground_truth_min_rgb']:.4f}")
    print(f"wrote {args.out} in {res['setup']['seconds']:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
