"""Voigt notation as CoefficientFunctions: strains as vectors with engineering shear
(ε11, ε22, 2ε12) or (ε11, ε22, ε33, 2ε23, 2ε13, 2ε12), stresses as vectors without the factor 2,
so that σ : ε is the dot product of the two vectors; and the symmetric matrices they stand for."""
import ngsolve as ngs


def matrix_cf(M):
    """A numpy matrix as a constant matrix-valued CoefficientFunction (a new one at each call:
    NGSolve's ``.trans`` of such a CF changes its dims in place, so one may not be shared)."""
    return ngs.CF(tuple(float(v) for v in M.flat), dims=M.shape)


def strain_vector(e, dim):
    """The Voigt strain vector of a symmetric strain matrix CF ``e``."""
    if dim == 2:
        return ngs.CF((e[0, 0], e[1, 1], 2 * e[0, 1]))
    return ngs.CF((e[0, 0], e[1, 1], e[2, 2], 2 * e[1, 2], 2 * e[0, 2], 2 * e[0, 1]))


def strain_matrix(s, dim):
    """The symmetric strain matrix CF of a Voigt strain vector ``s``."""
    if dim == 2:
        return ngs.CF((s[0], s[2] / 2, s[2] / 2, s[1]), dims=(2, 2))
    return ngs.CF((s[0], s[5] / 2, s[4] / 2, s[5] / 2, s[1], s[3] / 2, s[4] / 2, s[3] / 2, s[2]), dims=(3, 3))


def stress_vector(S, dim):
    """The Voigt stress vector of a stress matrix CF ``S``."""
    if dim == 2:
        return ngs.CF((S[0, 0], S[1, 1], S[0, 1]))
    return ngs.CF((S[0, 0], S[1, 1], S[2, 2], S[1, 2], S[0, 2], S[0, 1]))


def stress_matrix(s, dim):
    """The symmetric stress matrix CF of a Voigt stress vector ``s``."""
    if dim == 2:
        return ngs.CF((s[0], s[2], s[2], s[1]), dims=(2, 2))
    return ngs.CF((s[0], s[5], s[4], s[5], s[1], s[3], s[4], s[3], s[2]), dims=(3, 3))
