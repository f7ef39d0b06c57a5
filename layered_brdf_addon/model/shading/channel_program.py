"""The program of one channel or three (the RGB modes' triple): the lobes placed
(:func:`channel_lobes`), their amplitudes, the interference folded and the transmitted
closures (:func:`channel_block`); and the diffuse colour (:func:`diffuse_colour`).
"""
from __future__ import annotations

from ..params import WAVELENGTHS_NM
from .amplitudes import diffuse_rho, film_amplitudes, film_diffuse_rho, lobe_amplitudes
from .fold import FOLD_BASIS, fold_basis, fold_interference
from .energy import carried
from .lobes import closure_tangent, lobe_shape
from .placement import lobe_geometry
from .values import channels, gather, spread


def diffuse_colour(ops, P, d, wavelengths=WAVELENGTHS_NM, band=False, dispersion=True, interference=True,
                   footprint=False, optics="paper", orders=1):
    """``kd base rho_d`` per channel (eq. 14), the three channels as one triple; without
    ``interference`` (a layer so thick that it averages out over the band) ``rho_d = 1``
    (with thin-film optics, the film's mean transmission, twice)."""
    if optics == "physical":
        rho = film_diffuse_rho(ops, ops.combine(*P["r1"]), P["r0"], ops.combine(*P["r2"]), ops.combine(*P["k2"]),
                               ops.triple(*wavelengths), d, band=band, dispersion=dispersion, footprint=footprint,
                               orders=orders, interference=interference)
        colour = ops.named("diffuse_colour", ops.combine(*P["base"]) * (P["kd"] * rho))
        return ops.components(colour)
    if not interference:
        return tuple(P["kd"] * b for b in P["base"])
    rho = diffuse_rho(ops, ops.combine(*P["r1"]), P["r0"], ops.triple(*wavelengths), d, band=band,
                      dispersion=dispersion, footprint=footprint)
    colour = ops.named("diffuse_colour", ops.combine(*P["base"]) * (P["kd"] * rho))
    return ops.components(colour)


def channel_lobes(ops, r1, e0, e1, r0, n0, n1, v, lobe="beckmann", interference=True, energy=False):
    """The lobes of one channel or three (``r1`` a scalar or a triple) as closures would
    place them: :func:`lobe_geometry`, the fold's basis, and per channel the transmitted
    closure's normal ``N_T``, tangent ``U_T``, exponent, alpha, anisotropy and inverse
    peak (a lobe centred on the direction c is a closure about normalize(v + c)); ``energy``: the
    physical mode's energy-keeping closures (:func:`.lobes.lobe_peak`)."""
    cos_v = ops.clamp(ops.dot(v, n0), 0.0, 1.0)
    r_v = n0 * (2.0 * ops.dot(v, n0)) - v
    geo = lobe_geometry(ops, r1, e0, e1, r0, n0, n1, v, cos_v, r_v)
    out = {k: geo[k] for k in LOBE_PLACEMENT}
    out["cos_v"] = cos_v
    out["to_lower"] = geo["to_lower"]  # <t_o, n1>: the refracted view's cosine to the lower normal, negative
    if interference:
        out.update(fold_basis(ops, e0, geo["eT"], geo["eI"], geo["d_RT"], geo["d_RI"], geo["d_TI"]))
    n = 3 if ops.is_vector(r1) else 1
    normals = [ops.normalize(v + geo[f"l_star{k}"], n0) for k in range(n)]
    mu = spread(ops, gather(ops, [ops.dot(N, v) for N in normals]), r1)
    inv_peak, alpha, aniso = lobe_shape(ops, mu, geo["eT"], geo["eT_within"], geo["eT_across"], lobe=lobe,
                                       energy=energy)
    frames = [closure_tangent(ops, N, v, a) for N, a in zip(normals, channels(ops, aniso))]
    out.update(e_T=geo["eT"], alpha_T=alpha, inv_peak_T=inv_peak, aniso_T=gather(ops, [f[1] for f in frames]))
    out.update({f"N_T{k}": N for k, N in enumerate(normals)})
    out.update({f"U_T{k}": f[0] for k, f in enumerate(frames)})
    return out


LOBE_PLACEMENT = ("cos_ls", "cos_ci", "tail", "through", "atten")  # what lobe_amplitudes takes from the lobes


def channel_block(ops, r1, lam, e0, e1, ks, r0, n0, n1, v, d, r1_lobes=None, n2=None, k2=None, lobe="beckmann",
                  interference=True, band=False, footprint=False, optics="paper", orders=1):
    """The channels' lobes (eqs. 3-11), the interference folded into the other two, and the
    normals, exponents, alphas and weights of their transmitted closures (``N_T0``.., one
    per lobe direction).  ``r1``, ``lam``: a scalar (one wavelength) or a triple (the RGB
    channels); ``r1_lobes``: the index that places the lobes, where the channels share
    them (equal indices), else ``r1``; ``band``: the interference integrated over each RGB
    channel's band (the analytic mode), with ``footprint`` over the pixel's too; ``optics``:
    the paper's amplitudes or thin-film optics' (:func:`film_amplitudes`, the lower medium
    ``n2 + i k2``, ``orders`` harmonics)."""
    lobes = channel_lobes(ops, r1 if r1_lobes is None else r1_lobes, e0, e1, r0, n0, n1, v, lobe, interference,
                          energy=optics == "physical")
    placed = [spread(ops, lobes[k], r1) for k in LOBE_PLACEMENT]
    modes = dict(interference=interference, band=band, dispersion=r1_lobes is None, footprint=footprint)
    e_T = spread(ops, lobes["e_T"], r1)
    if optics == "physical":
        AR, AT, AI = film_amplitudes(ops, r1, lam, e0, e_T, e0, ks, r0, n2, k2, d, lobes["cos_v"], *placed,
                                     orders=orders, **modes)
    else:
        AR, AT, AI = lobe_amplitudes(ops, r1, lam, e0, e1, ks, r0, d, lobes["cos_v"], *placed, **modes)
    if interference:
        AR, AT = fold_interference(ops, AR, AT, AI, {k: spread(ops, lobes[k], r1) for k in FOLD_BASIS})
    out = dict(lobes, AR=AR, w_T=AT * spread(ops, lobes["inv_peak_T"], r1))
    keys = ["AR", "w_T", "e_T", "alpha_T", "aniso_T"] + [k for k in out if k[:3] in ("N_T", "U_T")]
    if optics == "physical":
        # What the lobes reflect in all, per channel.
        out["reflected"] = carried(ops, AR, e0) + carried(ops, AT, e_T)
        keys.append("reflected")
    return {k: out[k] for k in keys}
