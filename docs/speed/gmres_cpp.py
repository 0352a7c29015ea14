#!/usr/bin/env python3
"""NGSolve's C++ GMRES against ngcontact's numpy GMRES (``gmres.gmres``) on a system
of the kind the kept factorisation solves (docs/speed.md): the Hertz half-disk's
elasticity matrix (P2, two refinements) changed on Γ3 and made non-symmetric, preconditioned
by the UMFPACK factorisation of the unchanged one. Prints, per repetition, both solvers'
iterations and times and the time of as many products + preconditioner solves (what both must
do), and the difference of the solutions.

    python docs/speed/gmres_cpp.py
"""
import time, numpy as np, ngsolve as ngs
from ngsolve import la
from ngcontact.scenes import hertz
from ngcontact.solve.linalg.gmres import gmres
m = hertz.mesh(2, None, 2, curve=2)
V = ngs.VectorH1(m, order=2, dirichlet="top")
u, v = V.TnT()
def eps(w): return ngs.Sym(ngs.Grad(w))
a = ngs.BilinearForm(2 * ngs.InnerProduct(eps(u), eps(v)) * ngs.dx + ngs.div(u) * ngs.div(v) * ngs.dx).Assemble()
b = ngs.BilinearForm(2 * ngs.InnerProduct(eps(u), eps(v)) * ngs.dx + ngs.div(u) * ngs.div(v) * ngs.dx
                     + 50 * u * v * ngs.ds("contact") + 0.3 * ngs.Grad(u)[0, 1] * v[0] * ngs.dx).Assemble()
inv = a.mat.Inverse(V.FreeDofs(), inverse="umfpack")
f = ngs.LinearForm(ngs.CF((0, -1)) * v * ngs.ds("contact")).Assemble()
free = np.array(list(V.FreeDofs()), dtype=bool)
print("ndof", V.ndof)
for rep in range(3):
    w = f.vec.CreateVector()
    t0 = time.perf_counter(); ok, k = gmres(b.mat, inv, f.vec, w, None, 1e-10, 200); t1 = time.perf_counter()
    w2 = f.vec.CreateVector(); w2[:] = 0
    its = []
    s = la.GMRESSolver(b.mat, inv, tol=1e-10, maxiter=200, callback=lambda i, r: its.append(i))
    t2 = time.perf_counter(); w2.data = s * f.vec; t3 = time.perf_counter()
    # cost of k applications of matvec + preconditioner
    x, y, z = f.vec.CreateVector(), f.vec.CreateVector(), f.vec.CreateVector(); x.data = f.vec
    t4 = time.perf_counter()
    for _ in range(k):
        y.data = b.mat * x; z.data = inv * y
    t5 = time.perf_counter()
    d = w - w2
    print(f"python gmres {k} its {t1-t0:.3f} s | ngsolve C++ GMRESSolver {len(its)} its {t3-t2:.3f} s | matvec+precond x{k} {t5-t4:.3f} s | diff {ngs.Norm(d)/ngs.Norm(w):.1e}")
