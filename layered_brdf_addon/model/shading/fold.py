"""The fold: the interference lobe of eq. 5, of either sign, folded into the reflected and
transmitted lobes by a non-negative least-squares fit of Gaussian lobes in the tangent plane
(docs/closure-decomposition.md); Cycles clamps a negative closure weight to 0.
"""
from __future__ import annotations

from .step import shader_function

FOLD_RIDGE = 1e-4  # ridge of the fold's 2x2 normal equations (equal lobes make them singular)


@shader_function
def lobe_correlation(ops, p, q, delta2):
    """Normalised overlap <gp, gq> / (|gp| |gq|) of two tangent-plane Gaussian lobes whose
    centres are ``delta2`` apart (squared), and ``1 - rho^2`` written without cancellation
    (equal lobes give rho -> 1, and float32 shaders would lose every digit)."""
    s = p + q
    qq = 2.0 * ops.sqrt(p * q) / s  # 1 for equal exponents
    x = 0.5 * (p * q) / s * delta2
    e = ops.exp(-x)
    rho = qq * e
    diff = (p - q) / s
    one_minus_rho2 = diff * diff + qq * qq * (1.0 - e * e)
    return rho, one_minus_rho2


@shader_function
def fold_basis(ops, eR, eT, eI, dRT, dRI, dTI):
    """The geometry of :func:`fold_interference`'s least-squares fit, which the lobes'
    exponents and centres (``d..``: squared angles between them) fix whatever the
    amplitudes: the norms ``u`` of Gaussian lobes ``g = exp(-e theta^2 / 2)`` in the
    tangent plane (``|g|^2 = 1/(2e)`` up to a common factor), their normalised overlaps
    ``rho`` and the determinant of the normal equations with a small ridge (equal lobes
    make them singular).  Wavelengths that share lobe centres share this."""
    eR = ops.maximum(eR, 1e-3)  # exponent 0 has no finite Gaussian norm
    eT = ops.maximum(eT, 1e-3)
    eI = ops.maximum(eI, 1e-3)
    uR = 1.0 / ops.sqrt(2.0 * eR)
    uT = 1.0 / ops.sqrt(2.0 * eT)
    uI = 1.0 / ops.sqrt(2.0 * eI)
    rRT, one_minus = lobe_correlation(ops, eR, eT, dRT)
    rRI, _ = lobe_correlation(ops, eR, eI, dRI)
    rTI, _ = lobe_correlation(ops, eT, eI, dTI)
    det = 2.0 * FOLD_RIDGE + FOLD_RIDGE * FOLD_RIDGE + one_minus  # (1 + ridge)^2 - rho^2
    return dict(uR=uR, uT=uT, uI=uI, rRT=rRT, rRI=rRI, rTI=rTI, det=det)


@shader_function
def fold_weights(ops, AR, AT, AI, uR, uT, uI, rRT, rRI, rTI, det):
    """Non-negative least-squares fit of ``AR gR + AT gT + AI gI`` by ``wR gR + wT gT`` in
    the basis of :func:`fold_basis`: ``(wR, wT)``.  Where the 2x2 solution has a negative
    weight, the better single-lobe fit is used."""
    aR, aT, aI = AR * uR, AT * uT, AI * uI  # coefficients on unit-norm lobes
    bR = aR + rRT * aT + rRI * aI
    bT = rRT * aR + aT + rTI * aI
    wR2 = ((1.0 + FOLD_RIDGE) * bR - rRT * bT) / det
    wT2 = ((1.0 + FOLD_RIDGE) * bT - rRT * bR) / det
    both = ops.gt(wR2, 0.0) * ops.gt(wT2, 0.0)
    wR1 = ops.maximum(bR, 0.0)
    wT1 = ops.maximum(bT, 0.0)
    r_better = ops.gt(bR * wR1, bT * wT1)  # the fit that removes more of ||f||^2
    wR = ops.select(both, wR2, ops.select(r_better, wR1, 0.0)) / uR
    wT = ops.select(both, wT2, ops.select(r_better, 0.0, wT1)) / uT
    return wR, wT


def fold_interference(ops, AR, AT, AI, basis):
    """The interference lobe of eq. 5 (``2 cos(2 Phi) sqrt(R T)``, of either sign) folded
    into the reflected and transmitted lobes: ``(wR, wT)``, the non-negative least-squares
    fit of ``AR gR + AT gT + AI gI`` by ``wR gR + wT gT`` (:func:`fold_basis`,
    :func:`fold_weights`).  Cycles clamps a negative closure weight to 0, so destructive
    interference cannot be a closure of its own; constructive interference is folded too,
    which saves a closure per channel (docs/closure-decomposition.md has what that costs in
    accuracy and saves in time).  Works per channel on triples."""
    return fold_weights(ops, AR, AT, AI, *(basis[k] for k in FOLD_BASIS))


FOLD_BASIS = ("uR", "uT", "uI", "rRT", "rRI", "rTI", "det")
