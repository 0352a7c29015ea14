"""GMRES in numpy for Newton's corrections: left-preconditioned, in the block-scaled inner product
of Newton's norms (u in m and φ in V differ by orders of magnitude), not restarted (the kept
factorisation and the multigrid preconditioner keep the iterations few). The serial back-end
of ``krylov.Gmres``."""
import numpy as np


def gmres(matrix, preconditioner, r, w, weights, tol, maxiter):
    """Left-preconditioned GMRES from w = 0 for A w = r: minimises ‖M⁻¹(r − A w)‖ in the
    inner product (x, y) = Σ weights x y (Euclidean without weights) over the Krylov space,
    until it falls below ``tol`` times its start or after ``maxiter`` iterations.
    Returns (converged, iterations); w holds the solution."""
    n = len(w)
    weights = np.ones(n) if weights is None else weights
    work = w.CreateVector()
    work.data = preconditioner * r
    z = work.FV().NumPy()
    beta = float(np.sqrt(np.dot(weights * z, z)))
    w[:] = 0.0
    if beta == 0:
        return True, 0
    basis = np.empty((maxiter + 1, n))
    basis[0] = z / beta
    H = np.zeros((maxiter + 1, maxiter))
    cs, sn = np.zeros(maxiter), np.zeros(maxiter)
    g = np.zeros(maxiter + 1)
    g[0] = beta
    product = w.CreateVector()
    k, converged = 0, False
    while k < maxiter:
        w.FV().NumPy()[:] = basis[k]
        product.data = matrix * w
        work.data = preconditioner * product
        q = z.copy()
        for _ in range(2):                                     # classical Gram-Schmidt, twice
            c = basis[:k + 1] @ (weights * q)
            H[:k + 1, k] += c
            q -= c @ basis[:k + 1]
        H[k + 1, k] = np.sqrt(np.dot(weights * q, q))
        for i in range(k):                                     # the earlier Givens rotations
            H[i, k], H[i + 1, k] = cs[i] * H[i, k] + sn[i] * H[i + 1, k], -sn[i] * H[i, k] + cs[i] * H[i + 1, k]
        rho = np.hypot(H[k, k], H[k + 1, k])
        cs[k], sn[k] = H[k, k] / rho, H[k + 1, k] / rho
        H[k, k], H[k + 1, k] = rho, 0.0
        g[k], g[k + 1] = cs[k] * g[k], -sn[k] * g[k]
        k += 1
        if abs(g[k]) <= tol * beta or rho == 0:
            converged = True
            break
        basis[k] = q / np.sqrt(np.dot(weights * q, q))
    y = np.linalg.solve(np.triu(H[:k, :k]), g[:k]) if k else np.zeros(0)
    w.FV().NumPy()[:] = y @ basis[:k]
    return converged, k
