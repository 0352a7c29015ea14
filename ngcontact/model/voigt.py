"""Voigt matrices as CoefficientFunctions. The Voigt vectors of strains and stresses, and the
symmetric matrices they stand for, belong to a body's kinematics (``model.kinematics``)."""
from functools import lru_cache

import ngsolve as ngs


@lru_cache(maxsize=4096)
def constant(value):
    """The constant CoefficientFunction ``value``, made once per value: turning a float into one
    is NGSolve's slow step in building a constant matrix (a 6 × 6 one holds 36)."""
    return ngs.CF(value)


def matrix_cf(M):
    """A numpy matrix as a constant matrix-valued CoefficientFunction (a new one at each call:
    NGSolve's ``.trans`` of such a CF changes its dims in place, so one may not be shared; its
    constant entries are shared, ``constant``)."""
    return ngs.CF(tuple(constant(float(v)) for v in M.flat), dims=M.shape)
