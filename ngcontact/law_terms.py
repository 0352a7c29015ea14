"""The parts of the step residual that nonlinear laws give (``laws``, the paper's (2.16)-(2.17)):

  N(x; v) = (F(ε(u)), ε(v)) + (A(c ε(u − û)), ε(v))      (``forms.nonlinear_bulk``)

(each only where a law replaces the linear tensor), with c and û the time scheme's. NGSolve
differentiates N for Newton (``BilinearForm.AssembleLinearization``); ``StepSystem`` adds
N(x) to the residual and N'(x) to the Jacobian at its positions in the bulk's pattern. Newton's
scales come from the laws' tangents at 0 (``scales``), not from the state.
"""
import ngsolve as ngs
import numpy as np

from . import forms
from .matrices import csr, matching_positions


class LawTerms:
    """N(x) and N'(x) on the product space ``X`` for the MaterialTensors ``T`` with laws."""

    def __init__(self, T, X, coefficients):
        (u, _), (v, _) = X.TnT()
        self.form = ngs.BilinearForm(X, symmetric=False)
        self.form += forms.nonlinear_bulk(T, u, v, coefficients.rate, coefficients.anchor).Compile() * ngs.dx
        self.scales = ngs.BilinearForm(X, symmetric=False)          # the laws' tangents at 0
        tangent = 0
        if T.F_law is not None:
            tangent = tangent + forms.b(T, u, v)
        if T.A_law is not None:
            tangent = tangent + coefficients.rate * forms.a(T, u, v)
        self.scales += tangent * ngs.dx
        self.residual = ngs.GridFunction(X).vec
        self.linearized = False
        self._positions = {}

    def assemble_scales(self):
        """The tangents at 0 for the step's rate coefficient c (with each new c), and their
        diagonal."""
        self.scales.Assemble()
        self._diagonal = csr(self.scales.mat).diagonal()

    def apply(self, x):
        """N(x), in ``residual``."""
        self.form.Apply(x, self.residual)
        return self.residual

    def add_tangent(self, x, target):
        """target += N'(x) (target: a matrix of the bulk's pattern)."""
        self.form.AssembleLinearization(x)
        self.linearized = True
        positions = self._positions.get(id(target))
        if positions is None:
            positions = self._positions[id(target)] = matching_positions(self.form.mat, target)
        source, into = positions
        target.AsVector().FV().NumPy()[into] += self.form.mat.AsVector().FV().NumPy()[source]

    def diagonal(self):
        """The diagonal of the tangents at 0 (numpy): Newton's scales."""
        return self._diagonal

    def magnitude(self, x):
        """|N'| |x| + |N(x)| (numpy) by the last tangent (the one at 0 before any): the size of
        the laws' terms in the residual."""
        tangent = self.form.mat if self.linearized else self.scales.mat
        return abs(csr(tangent)) @ np.abs(x) + np.abs(self.residual.FV().NumPy())
