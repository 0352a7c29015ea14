"""Voigt matrices as CoefficientFunctions. The Voigt vectors of strains and stresses, and the
symmetric matrices they stand for, belong to a body's kinematics (``model.kinematics``)."""
import ngsolve as ngs


def matrix_cf(M):
    """A numpy matrix as a constant matrix-valued CoefficientFunction (a new one at each call:
    NGSolve's ``.trans`` of such a CF changes its dims in place, so one may not be shared)."""
    return ngs.CF(tuple(float(v) for v in M.flat), dims=M.shape)
