"""The Γ3 part of the step residual, R_Γ3(x), and its Jacobian R_Γ3'(x), as NGSolve forms.

For an integrand ``terms((u, φ), (v, ξ))`` (``integrands.contact_terms``: j_a + S − j_e, linear in
the test functions) on the ContactSide Γ3, R_Γ3 is a LinearForm in a copy of the state and
R_Γ3' a BilinearForm in the trial functions (NGSolve linearises it). Two ways to integrate:

* interpreted (``Compile()``) on ``side.on_facets`` (``ds(skeleton=True)`` on Γ3): NGSolve visits every
  facet of the mesh and evaluates the integrand on Γ3's only;
* compiled to machine code on the element boundaries of the volume elements at Γ3 only
  (``side.on_layer``, the integrand times the Γ3 indicator): the integrand is evaluated on every
  facet of those elements, which interpreted costs more than the visit of the whole mesh
  (docs/measurements.md, sections ngcontact/gamma3/terms.py and ngcontact/model/machine_code.py),
  compiled far less.

The Jacobian is compiled once a simulation's Newton iterations pay for it
(``machine_code.MachineCode``, ``use_machine_code``); the residual too where the mesh has at
least ``COMPILED_RESIDUAL_FACETS`` facets; compiled on ``on_layer`` it gives the same vector as
on ``ds`` to round-off.
"""
import ngsolve as ngs
import numpy as np

from ngcontact.model.machine_code import compiled

COMPILED_RESIDUAL_FACETS = 200_000
"""Facets of the mesh (the rank's part) from which the residual is compiled with the Jacobian:
the time each residual then saves repays the compile within a few steps (fitted to measurements
on the 3D reference block, docs/measurements.md, section ngcontact/gamma3/terms.py)."""


class Gamma3Terms:
    """R_Γ3 and R_Γ3' of ``terms`` on ``side`` over the product space ``X`` (module docstring).

    ``layer``: boolean array of the DOFs of the volume elements at Γ3 (where R_Γ3' has
    entries); ``mat``: R_Γ3' at the last ``linearize``; ``machine_code``: whether the Jacobian's
    integrand is compiled (``realcompile`` at once, or after ``use_machine_code``)."""

    def __init__(self, X, terms, side, realcompile=False):
        self.X, self.terms, self.side = X, terms, side
        self.layer = np.zeros(X.ndof, dtype=bool)
        for nr in np.flatnonzero(np.array(list(side.elements), dtype=bool)):
            self.layer[[d for d in X.GetDofNrs(ngs.ElementId(ngs.VOL, int(nr))) if d >= 0]] = True
        self.state = ngs.GridFunction(X)
        self.machine_code = False
        self._residual = self._residual_form(False)
        self.form = self._jacobian_form(False)
        if realcompile:
            self.use_machine_code()

    def _jacobian_form(self, realcompile):
        form = ngs.BilinearForm(self.X, symmetric=False)
        integrand = self.terms(self.X.TrialFunction(), self.X.TestFunction())
        if realcompile:
            form += self.side.on_layer(compiled(self.side.indicator * integrand, True, maxderiv=1))
        else:
            form += self.side.on_facets(integrand.Compile())
        return form

    def _residual_form(self, realcompile):
        form = ngs.LinearForm(self.X)
        integrand = self.terms(self.state.components, self.X.TestFunction())
        if realcompile:
            form += self.side.on_layer(compiled(self.side.indicator * integrand, True, maxderiv=0))
        else:
            form += self.side.on_facets(integrand.Compile())
        return form

    def use_machine_code(self):
        """From now on, assemble R_Γ3' (and, on meshes of ``COMPILED_RESIDUAL_FACETS`` facets,
        R_Γ3) with the integrand compiled to machine code: a compile once each (``machine_code.COMPILE_S``),
        the same values to round-off. Returns whether anything changed."""
        if self.machine_code:
            return False
        self.form = self._jacobian_form(True)
        if self.X.mesh.nfacet >= COMPILED_RESIDUAL_FACETS:
            self._residual = self._residual_form(True)
        self.machine_code = True
        return True

    @property
    def mat(self):
        return self.form.mat

    def residual(self, x):
        """R_Γ3(x) (a vector of the form, valid until the next call)."""
        self.state.vec.data = x
        self._residual.Assemble()
        return self._residual.vec

    def linearize(self, x):
        """R_Γ3'(x) into ``mat``."""
        self.form.AssembleLinearization(x)
