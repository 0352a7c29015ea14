"""The parts of the step residual that nonlinear laws give (``laws``, the paper's (2.16)-(2.17)):

  N(x; v) = (F(ε(u)), ε(v)) + (A(c ε(u − û)), ε(v))      (``forms.nonlinear_bulk``)
           + (the weak normal supports' terms with a law: ``forms.weak_normal_support_laws``)

(each only where a law replaces the linear tensor), with c and û the time scheme's. NGSolve
differentiates N for Newton (``BilinearForm.AssembleLinearization``); ``StepSystem`` adds
N(x) to the residual and N'(x) to the Jacobian at its positions in the bulk's pattern. Newton's
scales come from the laws' tangents at 0 (``scales``), not from the state.

After each step, and when Newton fails, the laws are held to their hypotheses at the run's own
strains (``law_watch``); where a law is steeper there than its stiffness scale allows, the
scale (Nitsche's γ, the penalty) is raised and the step solved again (``check_step``,
``rescaled``).

Quadrature: a law's stress is not a polynomial of the strain, so NGSolve's default rule for
ε(u):ε(v), of order 2(p − 1) (exact for the linear bulk), is not enough before h is far
below the law's strain scale; N is integrated with p more orders, 3p − 2 in all
(``BONUS_ORDER_PER_DEGREE`` × p; P1 keeps its one point, exact for constant strains).
On the manufactured contact case with fibre laws (docs/model.md) the P2 energy-error rates
scatter with the default rule and are 2 with p more orders (docs/measurements.md, section
ngcontact/solve/law_terms.py).
"""
import ngsolve as ngs
import numpy as np

from ngcontact.model import forms
from ngcontact import parallel
from ngcontact.solve.law_watch import CHANGED_HINT, LawViolation, LawWatch
from ngcontact.solve.linalg.matrices import Absolute, diagonal as matrix_diagonal, matching_positions


BONUS_ORDER_PER_DEGREE = 1
"""Extra quadrature orders for N, per polynomial degree p of u (``quadrature_order``)."""


def quadrature_order(p):
    """The order of the rule N is integrated with for u of degree p: NGSolve's default for
    ε(u):ε(v), 2(p − 1), plus the bonus (the energy balance test integrates with it and
    meets the solver's residual to round-off)."""
    return 2 * (p - 1) + BONUS_ORDER_PER_DEGREE * p


class LawTerms:
    """N(x) and N'(x) on the product space ``X`` for the laws of a ``WeakForm`` (its ``laws``:
    on Ω and on the weak normal supports)."""

    def __init__(self, weak_form, X):
        (u, _), (v, _) = X.TnT()
        T, kin, coefficients, order = weak_form.tensors, weak_form.kinematics, weak_form.coefficients, \
            weak_form.body.order
        self.form = ngs.BilinearForm(X, symmetric=False)
        bonus = BONUS_ORDER_PER_DEGREE * X.components[0].globalorder     # on NGSolve's 2(p − 1)
        for integral in weak_form.laws(u, v, bonus):
            self.form += integral
        self.scales = ngs.BilinearForm(X, symmetric=False)          # the laws' tangents at 0
        self.scales += weak_form.laws_tangent(u, v)
        self.residual = ngs.GridFunction(X).vec
        self.linearized = False
        self._positions = {}
        state = ngs.GridFunction(X)                    # a copy of the state the watches read
        u = state.components[0]
        self.watches = []
        if T.F_law is not None:
            self.watches.append(LawWatch(T.F_law, state, kin.strain_matrix(forms.strain(u, T)),
                                         quadrature_order(order)))
        if T.A_law is not None:
            rate = kin.strain_matrix(coefficients.rate * (forms.strain(u, T) - forms.strain(coefficients.anchor, T)))
            self.watches.append(LawWatch(T.A_law, state, rate, quadrature_order(order)))
        self._state, self._time, self._verified_at = state, coefficients.time, None
        for watch in self.watches:                     # this run's scales start from the laws as checked
            watch.bound.reset_scale()
        self.rescaled = []
        """(step, law, scale before, after) of each raised stiffness scale (Pa; Pa·s for A)."""

    def assemble_scales(self):
        """The tangents at 0 for the step's rate coefficient c (with each new c), and their
        diagonal."""
        self.scales.Assemble()
        self._diagonal = matrix_diagonal(self.scales.mat)

    def apply(self, x):
        """N(x), in ``residual``; at the first call of a step, after each law is found to be
        the one checked (``laws.BoundLaw.verify``: a Parameter it reads has not changed), else
        ``LawViolation``."""
        if self._verified_at != self._time.Get():          # a new step (its t_n): verify the laws
            for watch in self.watches:
                try:
                    watch.bound.verify(fresh=False)
                except ValueError as error:
                    raise LawViolation(watch.name(), str(error), step=None, time=self._time.Get(),
                                       hint=CHANGED_HINT) from None
            self._verified_at = self._time.Get()
        self.form.Apply(x, self.residual)
        return self.residual

    def add_tangent(self, x, target):
        """target += N'(x) (target: a matrix of the bulk's pattern; on a distributed mesh the
        rank's part, to which the rank's part of N'(x) adds)."""
        self.form.AssembleLinearization(x)
        self.linearized = True
        positions = self._positions.get(id(target))
        if positions is None:
            positions = self._positions[id(target)] = matching_positions(parallel.local_matrix(self.form.mat), target)
        source, into = positions
        target.AsVector().FV().NumPy()[into] += parallel.local_matrix(self.form.mat).AsVector().FV().NumPy()[source]

    def diagonal(self):
        """The diagonal of the tangents at 0 (numpy): Newton's scales."""
        return self._diagonal

    def magnitude(self, x):
        """|N'| |x| + |N(x)| (numpy) by the last tangent (the one at 0 before any): the size of
        the laws' terms in the residual (on a distributed mesh the rank's part, for x cumulated:
        ``StepSystem.magnitude`` sums them over the ranks)."""
        tangent = self.form.mat if self.linearized else self.scales.mat
        return Absolute(tangent) @ np.abs(x) + np.abs(self.residual.FV().NumPy())

    # ---------------------------------------------------------------- the laws at the run's strains
    def check_step(self, x, step, time, attempt=0):
        """Raise ``LawViolation`` if a law breaks (2.16)-(2.17) at the strains of the state
        ``x`` Newton accepted for ``step`` (at ``time``, s), or has changed since its check.
        True if a law's stiffness scale grew: the step is to be solved again with it (it has
        been ``attempt`` times); False: the strains are remembered, the state is kept
        (``law_watch``)."""
        self._state.vec.data = x
        grown = False
        for watch in self.watches:
            if watch.check(step, time, attempt):
                self.rescaled.append((step, watch.name(), *watch.rescaled))
                grown = True
        if not grown:
            for watch in self.watches:
                watch.keep()
        return grown

    def save(self):
        """The laws' stiffness scales and (on a serial mesh: the points are a rank's own) the
        strains and stresses of the last kept step at the watched points, as named arrays for a
        step's restart state (a resumed run decides as the uninterrupted one: ``solver_restart``)."""
        arrays, serial = {}, not parallel.is_distributed(self._state.space.mesh)
        for i, watch in enumerate(self.watches):
            arrays[f"law{i}_scale"] = np.asarray(watch.bound.scale.Get())
            if serial:
                arrays.update({f"law{i}_strain": np.asarray(watch.previous[0]),
                               f"law{i}_stress": np.asarray(watch.previous[1])})
        return arrays

    def load(self, arrays):
        """Put back what ``save`` gave (absent in archives written before: nothing is put back)."""
        for i, watch in enumerate(self.watches):
            if f"law{i}_scale" in arrays:
                watch.bound.scale.Set(float(arrays[f"law{i}_scale"]))
            if f"law{i}_strain" in arrays and np.shape(arrays[f"law{i}_strain"]) == np.shape(watch.previous[0]):
                watch.previous = (np.array(arrays[f"law{i}_strain"]), np.array(arrays[f"law{i}_stress"]))

    def explain(self, x, reason, hint):
        """(reason, hint) of a Newton failure at the iterate ``x``, with the law named where
        it is the likely cause (``law_watch``); unchanged otherwise."""
        self._state.vec.data = x
        self._verified_at = None                # a retry verifies the laws again
        matrix = parallel.local_matrix(self.form.mat) if self.linearized else None
        for watch in self.watches:
            found = watch.diagnose(matrix)
            if found is not None:
                return f"{reason}: {found[0]}", f"{found[1]}; otherwise {hint}" if hint else found[1]
        return reason, hint
