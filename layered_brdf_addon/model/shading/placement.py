"""Where each channel's lobes lie and how wide they are (eqs. 4, 5, 10, 11): the view's path
into the layer and out of it, and the interference lobe's centre.  The index fixes these, not
the wavelength's phase, so wavelengths whose lobes share a closure share them.
"""
from __future__ import annotations

from .lobes import angle2
from .step import shader_function
from .values import channels, gather, spread


@shader_function
def layer_path(ops, eta, s_o, cos_v, n0, n1, v):
    """The view's path into the layer (eqs. 10, 11): ``-v`` refracted into the layer
    (``t_o``) and mirrored on the lower boundary: ``r``, with ``<r, n0>`` and ``<t_o, n1>``
    (eq. 11 needs ``<t_o, n1> < 0``: the path reaches the lower boundary)."""
    t_o = v * (-eta) + n0 * (eta * cos_v - s_o)
    to_n1 = ops.dot(t_o, n1)
    r = t_o - n1 * (2.0 * to_n1)
    return r, ops.dot(r, n0), to_n1


@shader_function
def exit_direction(ops, eta, cos_r, e1):
    """Where the in-layer direction ``r`` (cosine ``cos_r`` to ``n0``) leaves the layer: the
    light direction ``l* = a r + b n0`` (a unit vector), its cosine ``cos_l`` to ``n0``, the
    in-layer cosine ``cos_t`` of the path that leaves along it, and ``tail``.

    Where ``r`` leaves (inside the critical cone, ``sin theta_c = eta``), ``l*`` is ``r``
    refracted out and ``tail`` is 1.  Where it cannot (beyond the critical angle, or
    heading down) the in-layer lobe ``cos^e1`` about ``r`` still sends its tail out through
    the critical cone: ``l*`` is the exit direction, in the plane of ``r`` and ``n0``, where
    the tail's light is largest, and ``tail`` the lobe's value there (``exp(-e1 (1 - cos
    delta))``, ``delta`` the in-layer angle from ``r``).  Near grazing exit that light goes
    as ``u^2 cos^e1(delta0 + b u^2)`` (``u`` the exit cosine, ``delta0`` the angle of ``r``
    beyond the critical angle, ``b = eta / (2 cos theta_c)``; Snell's law and Schlick's
    ``1 - F ~ 5 u``): largest at ``u^2 = (sqrt(delta0^2 + 4 / e1) - delta0) / (2 b)``.
    Scalars or channel triples."""
    inv_eta = 1.0 / eta
    inv_eta2 = inv_eta * inv_eta
    k_l = (1.0 - inv_eta2) + inv_eta2 * (cos_r * cos_r)
    leaves = ops.gt(k_l, 0.0) * ops.gt(cos_r, 0.0)
    sin_r = ops.sqrt(ops.maximum(1.0 - cos_r * cos_r, 0.0))
    cos_c = ops.sqrt(ops.maximum(1.0 - eta * eta, 1e-6))
    delta0 = ops.maximum(sin_r * cos_c - cos_r * eta, 0.0)  # sin(theta_r - theta_c)
    u2 = ops.clamp((ops.sqrt(delta0 * delta0 + 4.0 / ops.maximum(e1, 1e-3)) - delta0) * (cos_c / eta), 4e-4, 1.0)
    u = ops.sqrt(u2)
    sin_x = ops.sqrt(1.0 - u2)
    sin_in = eta * sin_x
    cos_in = ops.sqrt(ops.maximum(1.0 - sin_in * sin_in, 0.0))
    cos_delta = cos_r * cos_in + sin_r * sin_in
    tail = ops.select(leaves, 1.0, ops.exp(-ops.maximum(e1, 0.0) * (1.0 - cos_delta)))
    s_l = ops.sqrt(ops.maximum(k_l, 0.0))
    # The tail's exit direction u n0 + sin_x p, with p = (r - cos_r n0) / sin_r.
    q = sin_x / ops.maximum(sin_r, 1e-6)
    a = ops.select(leaves, inv_eta, q)
    b = ops.select(leaves, s_l - inv_eta * cos_r, u - cos_r * q)
    return a, b, ops.select(leaves, s_l, u), ops.select(leaves, cos_r, cos_in), tail


@shader_function
def interference_centre(ops, e0, e1p, w_sum, e01, d_RT, cos_v, cos_l):
    """The interference lobe's centre ``c_I = (e0 r_v + e1' l*) / L`` (eq. 5: the weighted
    centre of the reflected and transmitted lobes) without forming it: its cosine to
    ``n0`` and its squared chords ``d_RI``, ``d_TI`` to ``r_v`` and ``l*``, from the chord
    ``d_RT = 2 - 2 <r_v, l*>`` and the centres' cosines ``cos_v``, ``cos_l``.  Exact:
    ``L^2 = e0^2 + e1'^2 + 2 e0 e1' <r_v, l*> = (e0 + e1')^2 - e0 e1' d_RT``, at least
    ``(e0 - e1')^2``; ``w_sum``: ``e0 + e1'`` floored, so that two zero exponents give a
    zero lobe, not a division by zero; ``e01 = e0 e1'``."""
    inv_L = 1.0 / ops.maximum(ops.sqrt(w_sum * w_sum - e01 * d_RT), 1e-6)
    c = 1.0 - 0.5 * d_RT  # <r_v, l*>
    cos_ci = ops.clamp((e0 * cos_v + e1p * cos_l) * inv_L, 0.0, 1.0)
    d_RI = ops.maximum(2.0 - 2.0 * (e0 + e1p * c) * inv_L, 0.0)
    d_TI = ops.maximum(2.0 - 2.0 * (e1p + e0 * c) * inv_L, 0.0)
    return cos_ci, d_RI, d_TI


@shader_function
def lobe_geometry(ops, r1, e0, e1, r0, n0, n1, v, cos_v, r_v):
    """Where each channel's lobes lie and how wide they are (eqs. 4, 5, 10, 11): what the
    index ``r1`` fixes, but not the wavelength's phase.  ``r1``: a scalar (one channel) or
    a triple (three).  Wavelengths whose lobes share a closure share this
    (:func:`lobe_amplitudes` gives each its own amplitudes on it)."""
    eta = r0 / r1
    eta2 = eta * eta
    k_o = (1.0 - eta2) + eta2 * (cos_v * cos_v)
    s_o = ops.sqrt(k_o)  # <t_o, -n0>
    entering = ops.gt(k_o, 0.0) * ops.gt(cos_v, 0.0)
    # The light direction l* whose path through the layer leaves along v (eqs. 10, 11):
    # each channel's path, then how it leaves, computed on the channels at once.
    paths = [layer_path(ops, e, s, cos_v, n0, n1, v) for e, s in zip(channels(ops, eta), channels(ops, s_o))]
    cos_r = gather(ops, [p[1] for p in paths])
    to_n1 = gather(ops, [p[2] for p in paths])
    a, b, cos_ls, s_ls, tail = exit_direction(ops, eta, cos_r, e1)
    cos_ls = ops.clamp(cos_ls, 0.0, 1.0)
    # Eq. 11: no path, T = 0, and l* is the mirror direction.  A path whose centre cannot
    # leave keeps its tail.
    through = entering * ops.lt(to_n1, 0.0) * ops.gt(cos_ls, 0.0)
    l_stars = [ops.select_vec(ok, p[0] * ak + n0 * bk, r_v)
               for p, ok, ak, bk in zip(paths, channels(ops, through), channels(ops, a), channels(ops, b))]
    # The in-layer lobe seen from outside: exponent e1 / r1^2, times cos(l*)/cos(t) for the
    # stretch within the plane of incidence (geometric mean of the two directions).
    # Per axis (the closures are anisotropic): across the plane of incidence e1 / r1^2,
    # within it e1 / r1^2 (cos(l*)/cos(t))^2.
    stretch = ops.select(through, cos_ls / ops.maximum(s_ls, 1e-6), 1.0)
    e1_across = e1 / (r1 * r1)
    e1p = e1_across * stretch
    e1_within = e1p * stretch
    # Interference, eq. 5: sqrt(R T) of two Phong lobes is a lobe of exponent
    # (e0 + e1')/2 about their weighted centre, attenuated by their distance.
    w_sum = ops.maximum(e0 + e1p, 1e-6)
    d_RT = spread(ops, gather(ops, [angle2(ops, r_v, ls) for ls in l_stars]), r1)
    e01 = e0 * e1p
    atten = ops.exp(e01 * d_RT * (-0.25) / w_sum)
    cos_ci, d_RI, d_TI = interference_centre(ops, e0, e1p, w_sum, e01, d_RT, cos_v,
                                             ops.select(through, cos_ls, cos_v))
    out = dict(through=through, tail=tail, cos_ls=cos_ls, cos_ci=cos_ci, atten=atten, eT=e1p, to_lower=to_n1,
               eI=0.5 * (e0 + e1p), d_RT=d_RT, d_RI=d_RI, d_TI=d_TI, eT_within=e1_within, eT_across=e1_across)
    for k, ls in enumerate(l_stars):
        out[f"l_star{k}"] = ls
    return out
