"""The scalar laws on Γ3 (docs/model.md), as functions of a CoefficientFunction.

Each ``*_law(parameters)`` returns a function r ↦ CoefficientFunction, so a user may pass
any such function instead (it must be Lipschitz; kinks written with IfPos are linearised
semismoothly by Newton). ``checked`` samples such a function before it is used.
"""
import functools
import math

import ngsolve as ngs
from ngsolve.meshes import Make1DMesh

SAMPLES = (0.0, *(sign * 10.0 ** k for k in range(-12, 1) for sign in (1, -1)))
"""The arguments r (m) at which ``checked`` samples a law: 0 and ±10^k, k = −12 … 0."""


def positive_part(r):
    """[r]_+ = max(r, 0)."""
    return ngs.IfPos(r, r, 0)


def clip(r, low, high):
    """min(max(r, low), high)."""
    return ngs.IfPos(r - high, high, ngs.IfPos(low - r, low, r))


def compliance_law(c_nu):
    """p(r) = c_ν [r]_+ (2.20): the compliant layer pushes back once u_ν > 0; c_ν in Pa/m."""
    _nonnegative("compliance c_nu", c_nu, "Pa/m")
    return lambda r: c_nu * positive_part(r)


def bond_truncation(L, pressed=0.0):
    """R_ν(s) = L for s < -L, -s for -L <= s <= 0, 0 for s > 0 (docs/model.md's reading of (2.8));
    L > 0 is the bond length in m. At the kink s = 0 (a body at rest) the value is 0 either way;
    ``pressed`` (a number or Parameter in {0, 1}) picks the slope Newton linearises with there:
    0 the glued side's −1, 1 the pressed side's 0."""
    _positive("bond length L", L, "m")
    return lambda s: ngs.IfPos(-s - L, L, ngs.IfPos(s, 0.0, ngs.IfPos(-s, -s, (pressed - 1.0) * s)))


def potential_truncation(L_phi, widening=1.0):
    """φ_L(s) = max(-L_φ, min(s, L_φ)) (2.7, increasing as docs/model.md fixes it); L_φ in V.
    ``widening`` (a number or Parameter w > 0) makes the level L_φ w (``continuation``)."""
    _positive("potential truncation L_phi", L_phi, "V")
    return lambda s: clip(s, -L_phi * widening, L_phi * widening)


def conductance_ramp(k_e, delta, widening=1.0):
    """ψ(r) = k_e for r >= 0, k_e (1 + r/δ) for -δ <= r < 0, 0 for r < -δ (docs/model.md's default):
    full conductance k_e when the body touches the foundation (r = u_ν - g = 0). ``widening``
    (a number or Parameter w > 0) makes the ramp δ w (``continuation``)."""
    _nonnegative("conductance k_e", k_e, "")
    _positive("conductance ramp width delta", delta, "m")
    return lambda r: k_e * clip(1 + r / (delta * widening), 0, 1)


def conductance_literal(k_e, delta):
    """ψ(r) = 0 for r <= 0, k_e r/δ for 0 < r < δ, k_e for r >= δ: the paper's (2.24)
    read literally. Signorini keeps r = u_ν - g <= 0, so it conducts only through
    numerical penetration."""
    _nonnegative("conductance k_e", k_e, "")
    _positive("conductance ramp width delta", delta, "m")
    return lambda r: k_e * clip(r / delta, 0, 1)


def _positive(name, value, unit):
    if not value > 0:
        raise ValueError(f"{name} must be > 0{' ' + unit if unit else ''}, got {value}")


def _nonnegative(name, value, unit):
    if not value >= 0:
        raise ValueError(f"{name} must be >= 0{' ' + unit if unit else ''}, got {value}")


def checked(name, law, symbol, vanishes_from):
    """``law``, a function r ↦ CoefficientFunction (``symbol``: its name in the model, "p"
    or "ψ"), sampled at r in ``SAMPLES`` (at the time Parameter's current value): a
    TypeError if it cannot be called with a CoefficientFunction or does not return a
    CoefficientFunction, a ValueError naming ``name`` if it is not a real scalar, if a
    value is NaN, inf or negative, or nonzero for r <= ``vanishes_from`` (m): the compliant
    layer's p for r <= 0, the conductance ψ at a metre from the foundation and beyond (no
    conduction through a metre of air; the paper's ψ vanishes for r <= 0). A law that cannot
    be evaluated away from a mesh (it uses normals or fields of Γ3) is not sampled."""
    r = ngs.Parameter(0.0)
    try:
        value = law(r)
    except Exception as err:                                     # the user's function, any error
        raise TypeError(f"{name} must be a function r ↦ CoefficientFunction; called with a CoefficientFunction "
                        f"it raised {type(err).__name__}: {err}") from None
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        value = ngs.CF(float(value))
    if not isinstance(value, ngs.CoefficientFunction):
        raise TypeError(f"{name} must return a CoefficientFunction, got {value!r}")
    if value.dim != 1 or value.is_complex:
        raise ValueError(f"{name} must return a real scalar CoefficientFunction, got "
                         f"{'a complex' if value.is_complex else f'a {value.dim}-component'} one")
    for s in SAMPLES:
        r.Set(s)
        try:
            v = value(_point()[1])
        except Exception:                                        # NGSolve: needs a point of Γ3
            return law
        if not math.isfinite(v) or v < 0 or (s <= vanishes_from and v != 0):
            rule = f"{symbol} must be finite, >= 0, and 0 for r <= {vanishes_from:g} m"
            raise ValueError(f"{name}: the law {symbol}(r) is {v:.4g} at r = {s:g} m; {rule}")
    return law


@functools.cache
def _point():
    """(a one-element 1D mesh, a point of it), where a law of r alone is evaluated."""
    mesh = Make1DMesh(1)
    return mesh, mesh(0.5)
