"""A cheap error indicator of a step by averaged fluxes (Zienkiewicz–Zhu), for marking.

The step's stress σ_h and electric displacement D_h (``forms``; the same as the equilibrated
estimator's) are discontinuous across the elements; their averages σ_a, D_a (``GridFunction.Set``
onto continuous P_p, p the order of u and of φ: an element-wise projection averaged at shared
DOFs) are smoother, and the distance between the two, in the energy of the step,

  η_K² = ‖C_c^{−½}(σ_a − σ_h)‖²_K + ‖C^{−½}(D_a − D_h)‖²_K,

is large where the discrete flux jumps: near the contact zone's ends, clamped corners, load
edges. On the elements at Γ3 it adds the residual of the contact traction,

  η_Γ3,K² = λ_max(C_c^{−1}) (h_K / p) ‖σ_h ν − T_h‖²_{∂K∩Γ3},

T_h the traction the Γ3 terms exert at each point (``equilibrated.pointwise_data``), since the
averages see no boundary data and the contact zone's ends are where a step's error sits.

It is **not a bound** (no constant is known for it), but it costs a projection and two
integrals per step, about a tenth of the equilibrated estimate (``equilibrated``), and it marks
the same places: ``adapt`` marks by it and asks the equilibrated estimate for the certificate
(``marking="averaging"``). The electric charge flux on Γ3 has no residual term here. On a body
of revolution σ_h holds the hoop stress too and every integral is weighted by 2π r.
"""
import ngsolve as ngs
import numpy as np

from ngcontact.model import forms
from .equilibrated import Estimate, check, pointwise_data


class AveragingIndicator:
    """The indicator of the module docstring for the simulation ``sim`` (or its ``steps``); the
    averaging spaces are made once, ``__call__`` indicates the current step: an ``Estimate``
    (total = (Σ η_K²)^½, parts "stress", "flux" and "contact", indicators η_K) that is not a
    bound."""

    def __init__(self, sim):
        steps = check(sim)
        body = steps.body
        self.steps, self.body = steps, body
        mesh = body.mesh
        self._sigma = ngs.GridFunction(ngs.H1(mesh, order=max(body.order, 1)) ** body.kinematics.size)
        self._D = ngs.GridFunction(ngs.H1(mesh, order=max(body.order_phi, 1)) ** body.dim) if steps.electric else None
        self._order = 2 * max(body.order, body.order_phi)
        self._gamma3 = None
        if steps.contact is not None:
            traction, _ = pointwise_data(steps)
            side = steps.gamma3.side
            h = ngs.specialcf.mesh_size
            tests = ngs.L2(mesh, order=0)
            self._gamma3 = (traction, side, h / body.order, tests)

    def __call__(self):
        steps, body = self.steps, self.body
        T, mesh = body.tensors, body.mesh
        coefficients = steps.system.coefficients
        rate = coefficients.rate.Get() if T.viscous else 0.0
        strain_rate = rate * (forms.strain(steps.u, T) - forms.strain(coefficients.anchor, T)) if T.viscous else None
        sigma_h = forms.stress(T, steps.u, steps.phi, strain_rate).Compile()
        self._sigma.Set(sigma_h)
        compliance = forms.matrix_cf(np.linalg.inv(T.F + rate * T.A if T.viscous else T.F))
        diff = ngs.CF(self._sigma) - sigma_h
        parts = {"stress": ngs.InnerProduct(compliance * diff, diff)}
        if self._D is not None:
            D_h = forms.electric_displacement(T, steps.u, steps.phi).Compile()
            self._D.Set(D_h)
            dD = ngs.CF(self._D) - D_h
            parts["flux"] = ngs.InnerProduct(forms.matrix_cf(np.linalg.inv(T.C)) * dD, dD)
        squares = {name: np.maximum(ngs.Integrate(body.weighted(cf).Compile(), mesh, ngs.VOL, order=self._order,
                                                  element_wise=True).NumPy(), 0.0) for name, cf in parts.items()}
        if self._gamma3 is not None:
            traction, side, scale, tests = self._gamma3
            compliance_max = float(np.linalg.eigvalsh(np.linalg.inv(T.F + rate * T.A if T.viscous else T.F)).max())
            sigma_n = body.kinematics.traction(sigma_h, ngs.specialcf.normal(body.dim))
            r = sigma_n - traction
            form = ngs.LinearForm(tests)
            integrand = (side.indicator * compliance_max * scale * ngs.InnerProduct(r, r)).Compile()
            form += side.on_layer(integrand * tests.TestFunction())
            squares["contact"] = np.maximum(form.Assemble().vec.FV().NumPy().copy(), 0.0)
        indicators = np.sqrt(sum(squares.values()))
        values = {name: float(np.sqrt(v.sum())) for name, v in squares.items()}
        values.setdefault("flux", 0.0)
        return Estimate(total=float(np.sqrt(np.sum(indicators ** 2))), parts=values, indicators=indicators)
