"""The spectral modes: the channel program at N wavelengths, ``r1(lambda)`` from the Cauchy
fit through the three indices, summed into RGB closures with the baked CIE 1931 / D65
weights (``model/data/spectral_tables.json``), one wavelength after the other.
"""
from __future__ import annotations

from ..params import WAVELENGTHS_NM, LayeredParams
from ..plan import EffectPlan
from ..spectral_tables import tables
from .amplitudes import diffuse_rho, film_amplitudes, film_diffuse_rho, lobe_amplitudes
from .channel_program import LOBE_PLACEMENT, channel_lobes
from .closures import Closure, ShadingResult
from .fold import FOLD_BASIS, fold_weights
from .energy import carried
from .lobes import closure_for
from .thin_film import optics_settings
from .values import channels, gather, spread


def channel_range(name: str) -> tuple[float, float]:
    """The range of a per-channel parameter (``r1_r``...), which a wavelength's value mapped through the
    channels' values is kept within: the parameter table's."""
    spec = LayeredParams.spec(name)
    return spec.min, spec.max


def spectral_step(ops, acc_R, acc_D, acc_T, r1, lam, m, e0, e1, ks, r0, d, cos_v, cos_ls, cos_ci, tail, through,
                  atten, uR=None, uT=None, uI=None, rRT=None, rRI=None, rTI=None, det=None, n2=None, k2=None, e_T=None,
                  diffuse=True, interference=True, optics="paper", orders=1):
    """One wavelength of the spectral mode, chained: it takes the running sums of the
    reflected, diffuse and its lobe group's transmitted light and returns them updated, so
    a shader holds only the sums, whatever the number of wavelengths.  The lobes are its
    group's (:func:`channel_lobes` of the group's lead wavelength, computed once); only
    the amplitudes are the wavelength's own.  ``m``: the wavelength's row of the
    spectrum-to-Rec.709 matrix (a vector)."""
    out = {}
    # Everything this step computes depends on the index, which waits for the whole
    # previous state, so that a node backend evaluates the steps one after the other and
    # only the running state stays alive, whatever the number of wavelengths (Cycles' SVM
    # has a stack of 255 floats).
    r1 = ops.after((acc_R, acc_D, acc_T), r1)
    if not diffuse:
        out["acc_D"] = acc_D
    elif optics == "physical":
        out["acc_D"] = acc_D + m * film_diffuse_rho(ops, r1, r0, n2, k2, lam, d, orders=orders,
                                                    interference=interference)
    elif not interference:
        out["acc_D"] = acc_D + m  # rho_d averaged over the band: 1
    else:
        out["acc_D"] = acc_D + m * diffuse_rho(ops, r1, r0, lam, d)
    if optics == "physical":
        AR, AT, AI = film_amplitudes(ops, r1, lam, e0, e_T, e0, ks, r0, n2, k2, d, cos_v, cos_ls, cos_ci, tail, through,
                                     atten, interference=interference, orders=orders)
    else:
        AR, AT, AI = lobe_amplitudes(ops, r1, lam, e0, e1, ks, r0, d, cos_v, cos_ls, cos_ci, tail, through, atten,
                                     interference=interference)
    if interference:
        AR, AT = fold_weights(ops, AR, AT, AI, uR, uT, uI, rRT, rRI, rTI, det)
    out["acc_R"] = acc_R + m * AR
    out["acc_T"] = acc_T + m * AT
    return out


_UNIT = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def spectral_groups(lams, dispersion: bool):
    """Lobe group of each wavelength (the nearest of the three RGB wavelengths with
    dispersion, one group without) and, per group, the wavelength whose lobe it uses."""
    groups = [min(range(3), key=lambda c: abs(WAVELENGTHS_NM[c] - lam)) if dispersion else 0 for lam in lams]
    leads = {}
    for g in sorted(set(groups)):
        centre = WAVELENGTHS_NM[g] if dispersion else WAVELENGTHS_NM[1]
        leads[g] = min((j for j in range(len(lams)) if groups[j] == g), key=lambda j: abs(lams[j] - centre))
    return groups, leads


def merged_group_weights(ops, accs):
    """Closure weights (r, g, b) of the lobe groups from their Rec.709 sums ``accs``.

    A group's sum can be negative in a channel (the colour matching functions are: the
    green group's wavelengths subtract red), and Cycles clamps a closure weight at 0.
    Clamping each group alone would discard that negative part and add its light back;
    instead, per channel, the negative parts are taken from the groups' positive parts in
    proportion, so the groups' total keeps the channel's sum (clamped at 0 only if the sum
    itself is negative)."""
    out = [[None] * 3 for _ in accs]
    for c in range(3):
        parts = [ops.dot(acc, _UNIT[c]) for acc in accs]
        if len(parts) == 1:
            out[0][c] = ops.maximum(parts[0], 0.0)
            continue
        pos = [ops.maximum(x, 0.0) for x in parts]
        total, pos_total = parts[0], pos[0]
        for x, q in zip(parts[1:], pos[1:]):
            total = total + x
            pos_total = pos_total + q
        scale = ops.maximum(total, 0.0) / ops.maximum(pos_total, 1e-30)
        for g, q in enumerate(pos):
            out[g][c] = q * scale
    return [tuple(w) for w in out]


def shade_spectral(ops, P, n0, n1, d, v, plan: EffectPlan) -> ShadingResult:
    """Spectral mode: the channel program at N wavelengths (``r1(lambda)`` from the Cauchy
    fit through the three indices, a linear map), summed into RGB closures with baked
    CIE 1931 / D65 weights (model/spectral_tables.py).  Transmitted lobes keep a bounded
    number of directions: each wavelength joins the lobe group of the nearest of the three
    RGB wavelengths (three groups with dispersion, one without), whose lobes are placed
    once, by the group's wavelength nearest to it; each wavelength adds its own amplitudes
    on them.
    """
    t = tables(plan.spectral)
    lams, K, M = t["wavelengths"], t["cauchy"], t["rgb"]
    groups, leads = spectral_groups(lams, plan.dispersion)

    def through_channels(j, values, lo, hi):
        k = K[j]
        return ops.clamp(k[0] * values[0] + k[1] * values[1] + k[2] * values[2], lo, hi)

    def index(j):
        return through_channels(j, P["r1"], *channel_range("r1_r"))

    optics = optics_settings(plan)

    def lower_medium(j):
        """The lower medium's n and k at wavelength j, by the same map through the channels' values."""
        if not optics:
            return {}
        return dict(n2=through_channels(j, P["r2"], *channel_range("r2_r")),
                    k2=through_channels(j, P["k2"], *channel_range("k2_r")))

    order = sorted(leads)
    lead_r1 = gather(ops, [index(leads[g]) for g in order])
    lobes = ops.call("lobe groups", channel_lobes,
                     dict(r1=lead_r1, e0=P["e0"], e1=P["e1"], r0=P["r0"], n0=n0, n1=n1, v=v),
                     lobe=plan.lobe, interference=plan.interference, energy=bool(optics))
    per_group = list(LOBE_PLACEMENT + (FOLD_BASIS if plan.interference else ()) + (("e_T",) if optics else ()))
    split = {k: channels(ops, spread(ops, lobes[k], lead_r1)) for k in per_group}
    zero = (0.0, 0.0, 0.0)
    acc_R, acc_D, acc_T = zero, zero, {g: zero for g in order}
    for j, (lam, m) in enumerate(zip(lams, M)):
        g = groups[j]
        slot = order.index(g)
        state = ops.call("spectral step", spectral_step,
                         dict(acc_R=acc_R, acc_D=acc_D, acc_T=acc_T[g], r1=index(j), lam=float(lam),
                              m=tuple(float(x) for x in m), e0=P["e0"], e1=P["e1"], ks=P["ks"], r0=P["r0"], d=d,
                              cos_v=lobes["cos_v"], **{k: split[k][slot] for k in per_group}, **lower_medium(j)),
                         diffuse=plan.diffuse, interference=plan.interference, **optics)
        acc_R, acc_D, acc_T[g] = state["acc_R"], state["acc_D"], state["acc_T"]
    res = ShadingResult()

    def rgb(vec):
        return tuple(ops.maximum(ops.dot(vec, _UNIT[c]), 0.0) for c in range(3))

    if plan.diffuse:
        res.diffuse = tuple(P["kd"] * b * x for b, x in zip(P["base"], rgb(acc_D)))
    if not plan.specular:
        return res
    res.glossy.append(closure_for(ops, plan.lobe, "reflect", n0, P["e0"], v, rgb(acc_R), energy=bool(optics)))
    e, alpha, aniso = (channels(ops, lobes[k]) for k in ("e_T", "alpha_T", "aniso_T"))
    if optics:
        # What the lobes reflect in all, per channel.
        reflected = carried(ops, acc_R, P["e0"])
        for slot, g in enumerate(order):
            reflected = reflected + carried(ops, acc_T[g], e[slot])
        res.extras["reflected"] = ops.combine(*rgb(reflected))
    inv_peak = channels(ops, lobes["inv_peak_T"])
    weights = merged_group_weights(ops, [acc_T[g] * inv_peak[slot] for slot, g in enumerate(order)])
    for slot, (g, w) in enumerate(zip(order, weights)):
        res.glossy.append(Closure(f"transmit_{g}", lobes[f"N_T{slot}"], e[slot], alpha[slot], w, aniso[slot],
                                  lobes[f"U_T{slot}"]))
    return res
