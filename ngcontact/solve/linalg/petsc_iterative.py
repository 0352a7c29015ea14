"""Newton's corrections by PETSc's GMRES preconditioned with Γ3 solves around block algebraic
multigrid: the iterative solver of large steps on PETSc, serial or distributed.

The step Jacobian J (``system``; non-symmetric, indefinite: ``multigrid`` has the blocks) is
solved by PETSc's GMRES in Newton's weighted norm (``krylov``) with the Γ3 – bulk – Γ3
preconditioner (``gamma3_bulk``) on PETSc's parts instead of nested meshes:

  S: MUMPS's LU of J on the free DOFs of the Γ3 facets (a surface problem, ~n^(2/3) DOFs,
     factorised at every Newton iteration: it carries the stiff Γ3 terms that change there);
  B: diag(GAMG_u, −GAMG_φ), PETSc's smoothed-aggregation algebraic multigrid (``PCGAMG``) of
     the SPD forms of ``forms.preconditioner_forms`` (u: the piezo-stiffened elasticity plus
     c times the viscosity; φ: the permittivity), u with the rigid-body motions as its near
     null space (without them GAMG needs more CG iterations) and its rows ordered node by
     node with block size d (``petsc_blocks.node_by_node``: GAMG aggregates nodes);

  y = S r;  y += B (r − J y);  y += S (r − J y),

the two products with J taken by its strips J[:, Γ3] (y = S r is zero off Γ3) and J[Γ3, :]
(S reads Γ3's rows only), cheaper than products with all of J (docs/measurements.md, section
ngcontact/solve/linalg/petsc_iterative.py).

No nested meshes are needed (NGSolve cannot refine a distributed mesh, so its multigrid does
not run there), and every part runs on every rank. B's u part is built anew when the rate
coefficient c changes (``system.generation``; its φ part has no c and is kept), S at every
solve. A GMRES that does not reach
its tolerance within ``maxiter`` iterations is counted (``krylov_failures``, in the step's
record) and the correction is solved by a fresh MUMPS factorisation of J instead
(``petsc_solver.MumpsFactorization``, counted in ``factorizations``) where that is expected to
fit in memory (``factorisation_fits``; else GMRES's last iterate stands, counted in
``oversized``, and Newton goes on or the step is cut back); if the factorisation fails, the
error names both reasons.

PETSc options reach the parts through the prefixes ``ngcontact_u_`` and ``ngcontact_phi_``
(the GAMG preconditioners, e.g. ``-ngcontact_u_pc_gamg_threshold 0.02``; ``GAMG_OPTIONS`` are
the defaults) and
``ngcontact_gamma3_`` (the Γ3 factorisation); those of ``Simulation(solver={"pc_type": "gamg",
...})`` reach both GAMG preconditioners under their prefixes (``options``).
"""
from contextlib import nullcontext

import ngsolve as ngs
import numpy as np

from ngcontact import parallel
from ngcontact.checks import node_memory
from ngcontact.model.machine_code import compile_bulk, compiled
from ngcontact.solve.linalg.petsc_blocks import index_set, node_by_node, petsc_vector, rigid_motion_values
from ngcontact.solve.linalg.petsc_options import given_options, reading_options
from ngcontact.solve.linalg import gamma3_bulk
from ngcontact.solve.linalg.krylov import Gmres
from ngcontact.solve.linalg.petsc_modules import load
from ngcontact.solve.linalg.petsc_solver import MumpsFactorization, PetscMatrix


GAMG_OPTIONS = {"pc_gamg_threshold": 0.01}
"""PETSc options of both GAMG preconditioners unless given (``PETSC_OPTIONS``): dropping the
graph's weak couplings below 0.01 (PETSc's default: none) coarsens less aggressively and takes
fewer GMRES iterations on the 3D block (docs/measurements.md, section
ngcontact/solve/linalg/petsc_iterative.py)."""


class GamgSolver:
    """w = J⁻¹ r by GMRES with the preconditioner of the module: the linear solver protocol of
    ``linear_solver`` (``solve(matrix, freedofs, r, w, generation, timer, weights, tol)``,
    counters ``factorizations`` (the Γ3 factorisations, the fallbacks), ``krylov_iterations``,
    ``krylov_failures``, and ``oversized``: the failures left to GMRES's last iterate because
    a factorisation would not fit in memory).

    Parameters
    ----------
    body : the Body.
    system : the StepSystem (its ``coefficients.rate``, 1/s, read when ``generation`` changes).
    layer : BitArray of the DOFs on the Γ3 facets, or None (no contact).
    tol : GMRES's relative reduction of the preconditioned residual (Newton asks for less
        where that suffices: ``margin``).
    maxiter : GMRES iterations before a solve counts as failed.
    realcompile : compile the preconditioner forms' integrands to machine code (True, False;
        None: from ``machine_code.BULK_COMPILED_FROM`` elements).
    options : the ``petsc_options.SolverOptions`` of ``Simulation(solver={...})``, or None: their
        ``database`` (``pc_gamg_*``, ``mg_levels_*``, ...) reaches both GAMG preconditioners (over
        ``GAMG_OPTIONS``), ``max_it`` replaces ``maxiter``, and ``rtol`` bounds the tolerance
        Newton asks for: GMRES reduces the residual by at least that much.

    ``forcing`` (0.01): after every correction but a step's first Newton asks for no more
    than ``inexact.forcing_term`` (0.01 (‖r_k‖ / ‖r_{k−1}‖)² after a fall, Eisenstat–Walker;
    0.01 ‖r_{k−1}‖ / ‖r_k‖ after a rise), so that corrections while the contact set still
    moves are not solved to the step's final accuracy: on the 3D block, about as many Newton
    iterations with far fewer GMRES iterations than with the forcing after falls only (the
    GMRES after a rise ran to ``maxiter``) or without it (docs/speed.md, docs/scale.md).
    """

    margin = 0.1
    forcing = 0.01

    def __init__(self, body, system, layer=None, *, tol=1e-8, maxiter=300, realcompile=None, options=None):
        load("solver='gamg'")
        self.body, self.system, self.layer, self.options = body, system, layer, options
        if options is not None and options.max_it is not None:
            maxiter = options.max_it
        self.tol, self.maxiter, self.realcompile = tol, int(maxiter), realcompile
        self.factorizations = self.krylov_iterations = self.krylov_failures = self.oversized = 0
        self._integrand = None                        # the preconditioner forms', compiled once
        self._generation = self.J = None
        self._bulk = None
        self._krylov = Gmres()

    name = "GMRES preconditioned by Γ3 MUMPS solves around block GAMG (PETSc)"

    def _setup(self, matrix):
        """The index sets of u, φ and the DOFs on Γ3 in J, a PETSc matrix new to the solver."""
        PETSc, _ = load()
        mapping, template = self.J.vectors, matrix.CreateColVector()
        n_u = self.body.V.ndof
        u_part = np.zeros(matrix.height)
        u_part[:n_u] = 1.0
        self.fields = [node_by_node(PETSc, mapping, template, index_set(PETSc, mapping, template, u_part, 1.0),
                                    self.body.dim, n_u),
                       index_set(PETSc, mapping, template, u_part, 0.0)]
        layer = np.zeros(matrix.height)
        if self.layer is not None:
            layer[np.array(list(self.layer), dtype=bool)] = 1.0
        self.surface_rows = index_set(PETSc, mapping, template, layer, 1.0)
        self._surface = self._surface_matrix = None
        self._near_null_space = None                  # GAMG's, for these rows: made once
        self._bulk = None                             # B for these rows (``_preconditioners``)
        self._d = self.J.mat.createVecRight()
        self._generation = None

    def _preconditioners(self, freedofs):
        """B: GAMG of the u and φ preconditioner forms at the current rate coefficient. The
        integrands are compiled once with c as the scheme's Parameter (compiling to machine code
        was a large share of what every new c cost: docs/measurements.md, section
        ngcontact/solve/linalg/petsc_iterative.py); at a new c φ's GAMG (the
        permittivity has no c) is kept, u's made anew."""
        PETSc, _ = load()
        previous = self._bulk or [None, None]
        if self._integrand is None:
            (u, phi), (v, xi) = self.system.X.TnT()
            u_integrand, phi_integrand = self.system.weak_form.preconditioner(u, v, phi, xi,
                                                                              self.system.coefficients.rate)
            self._integrand = compiled(u_integrand + phi_integrand,
                                       compile_bulk(self.realcompile, self.body.mesh.ne))
        form = ngs.BilinearForm(self.system.X, symmetric=True)
        form += self.body.kinematics.dx(self._integrand)
        form.Assemble()
        P = PetscMatrix(form.mat, freedofs).mat
        blocks = []
        for name, rows, kept in zip(("u", "phi"), self.fields, previous):
            if rows.getSize() == 0:
                blocks.append(None)
                continue
            if name == "phi" and kept is not None:
                blocks.append(kept)
                continue
            block = P.createSubMatrix(rows, rows)
            if name == "u":
                if self._near_null_space is None:
                    self._near_null_space = self._rigid_motions(PETSc, rows, block)
                block.setNearNullSpace(self._near_null_space)
            pc = PETSc.PC().create(comm=block.getComm())
            prefix = f"ngcontact_{name}_"
            pc.setOptionsPrefix(prefix)
            pc.setOperators(block)
            pc.setType("gamg")
            options = PETSc.Options()
            for key, value in GAMG_OPTIONS.items():          # the defaults, where PETSC_OPTIONS says nothing
                if not options.hasName(prefix + key):
                    options.setValue(prefix + key, value)
            what = f"the GAMG preconditioner of {name} (prefix -{prefix})"
            with reading_options(what), given_options(prefix, self.options.database if self.options else None, what):
                pc.setFromOptions()
                pc.setUp()
            x, y = block.createVecs()
            blocks.append((pc, x, y, PETSc.Scatter().create(self._d, rows, x, None)))
        self._bulk = blocks

    def _rigid_motions(self, PETSc, rows, block):
        """The rigid-body motions of u (translations, rotations about the axes), restricted to
        the free u DOFs and orthonormalised, as GAMG's near null space; made once per pattern
        (``_setup``), not per rate coefficient."""
        vectors = []
        gather = PETSc.Scatter().create(self._d, rows, block.createVecRight(), None)   # rows: not all owned here
        template = ngs.GridFunction(self.system.X).vec
        for values in rigid_motion_values(self.body, self.system.X):
            full = petsc_vector(self.J.vectors, template, values)
            vector = block.createVecRight()
            gather.scatter(full, vector, addv=PETSc.InsertMode.INSERT_VALUES, mode=PETSc.ScatterMode.FORWARD)
            for earlier in vectors:
                vector.axpy(-vector.dot(earlier), earlier)
            vector.normalize()
            vectors.append(vector)
        return PETSc.NullSpace().create(vectors=vectors, comm=block.getComm())

    def _factor_surface(self):
        """S: the MUMPS LU of J on the DOFs on Γ3 (its pattern analysed once, refactorised), and
        the two strips of J that M needs besides: J[:, Γ3] and J[Γ3, :]."""
        PETSc, _ = load()
        if self.surface_rows.getSize() == 0:
            self._surface = None
            return
        J = self.J.mat
        if self._surface is None:
            every = [PETSc.IS().createStride(end - start, first=start, step=1, comm=J.getComm())
                     for start, end in (J.getOwnershipRange(), J.getOwnershipRangeColumn())]
            self._strips = (every, J.createSubMatrix(every[0], self.surface_rows),     # J[:, Γ3]
                            J.createSubMatrix(self.surface_rows, every[1]))           # J[Γ3, :]
            self._surface_matrix = J.createSubMatrix(self.surface_rows, self.surface_rows)
            self._surface = PETSc.PC().create(comm=self._surface_matrix.getComm())
            self._surface.setOptionsPrefix("ngcontact_gamma3_")
            self._surface.setOperators(self._surface_matrix)
            self._surface.setType("lu")
            self._surface.setFactorSolverType("mumps")
            with reading_options("the Γ3 factorisation of solver='gamg' (prefix -ngcontact_gamma3_)"):
                self._surface.setFromOptions()
            self._sr, self._sy = self._surface_matrix.createVecs()
            self._sd, self._sz = self._surface_matrix.createVecs()
            self._on_surface = PETSc.Scatter().create(self._d, self.surface_rows, self._sr, None)   # J's vectors ↔ Γ3's
        else:
            every, columns, rows = self._strips
            J.createSubMatrix(self.surface_rows, self.surface_rows, submat=self._surface_matrix)
            J.createSubMatrix(every[0], self.surface_rows, submat=columns)
            J.createSubMatrix(self.surface_rows, every[1], submat=rows)
            self._surface.setOperators(self._surface_matrix)
        with reading_options("the Γ3 factorisation of solver='gamg' (prefix -ngcontact_gamma3_)"):
            self._surface.setUp()
        if self._surface.getFailedReason():
            raise ArithmeticError(f"the MUMPS factorisation of the Γ3 block failed (PETSc's reason "
                                  f"{self._surface.getFailedReason()})")
        self.factorizations += 1

    @property
    def surface(self):
        """Whether J has free DOFs on Γ3 (``gamma3_bulk.Parts``; the parts on J's PETSc vectors follow)."""
        return self._surface is not None

    def clear(self, y):
        y.set(0.0)

    def surface_solve(self, r, y):
        """y = S r: Γ3's rows move by one scatter made with S (``_factor_surface``)."""
        PETSc, _ = load()
        y.set(0.0)
        self._on_surface.scatter(r, self._sr, addv=PETSc.InsertMode.INSERT_VALUES, mode=PETSc.ScatterMode.FORWARD)
        self._surface.apply(self._sr, self._sy)
        self._on_surface.scatter(self._sy, y, addv=PETSc.InsertMode.INSERT_VALUES, mode=PETSc.ScatterMode.REVERSE)

    def defect(self, r, y):
        """r − J y for y = S r, zero off Γ3: J[:, Γ3] stands for J."""
        self._strips[1].mult(self._sy, self._d)
        self._d.aypx(-1.0, r)
        return self._d

    def surface_defect(self, r, y):
        """Γ3's rows of r − J y: J[Γ3, :] stands for J (two products with all of J per
        application otherwise)."""
        self._strips[2].mult(y, self._sd)
        self._sd.aypx(-1.0, self._sr)
        return self._sd

    def add_surface(self, s, y):
        PETSc, _ = load()
        self._surface.apply(s, self._sz)
        self._on_surface.scatter(self._sz, y, addv=PETSc.InsertMode.ADD_VALUES, mode=PETSc.ScatterMode.REVERSE)

    def add_bulk(self, r, y):
        """y += diag(GAMG_u, −GAMG_φ) r (each block's rows gathered from r and added back into
        y by a scatter made with the block)."""
        PETSc, _ = load()
        for sign, block in zip((1.0, -1.0), self._bulk):
            if block is None:
                continue
            pc, x, z, scatter = block
            scatter.scatter(r, x, addv=PETSc.InsertMode.INSERT_VALUES, mode=PETSc.ScatterMode.FORWARD)
            pc.apply(x, z)
            if sign < 0:
                z.scale(-1.0)
            scatter.scatter(z, y, addv=PETSc.InsertMode.ADD_VALUES, mode=PETSc.ScatterMode.REVERSE)

    def _apply(self, r, y):
        """y = M r (``gamma3_bulk``) on J's PETSc vectors."""
        gamma3_bulk.apply(self, r, y)

    def solve(self, matrix, freedofs, r, w, generation=None, timer=None, weights=None, tol=None, changing=None):
        """w = J⁻¹ r to the relative accuracy ``tol`` (default the solver's) in the ``weights``
        norm of the preconditioned residual (``changing`` is not used)."""
        timer = timer or (lambda phase: nullcontext())
        with timer("factorization"):
            previous, self.J = self.J, self._krylov.operator(matrix, freedofs)   # new, or refilled
            if self.J is not previous:
                self._setup(matrix)
            if generation != self._generation or self._bulk is None:
                self._preconditioners(freedofs)
                self._generation = generation
            self._factor_surface()
        tol = self.tol if tol is None else tol
        if self.options is not None and self.options.rtol is not None:
            tol = min(tol, self.options.rtol)
        with timer("solve"):
            converged, iterations, reason = self._krylov.solve(matrix, freedofs, self._apply, r, w, weights, tol,
                                                               self.maxiter, current=True)
        self.krylov_iterations += iterations
        if not converged:                      # a fresh factorisation of J solves instead, where it fits
            self.krylov_failures += 1
            if not factorisation_fits(self.body.ndof, self.body.dim, self.body.mesh):
                self.oversized += 1            # GMRES's last iterate stands: Newton goes on, or cuts back
                return
            with timer("factorization"):
                try:
                    exact = MumpsFactorization(matrix, freedofs)
                except ArithmeticError as error:
                    PETSc, _ = load()
                    names = {v: k for k, v in vars(PETSc.KSP.ConvergedReason).items() if not k.startswith("_")}
                    raise ArithmeticError(f"GMRES did not converge in {iterations} iterations (PETSc's reason "
                                          f"{names.get(reason, reason)}) and {error}") from None
                self.factorizations += 1
            with timer("solve"):
                w.data = exact * r

    def __repr__(self):
        return f"GamgSolver(tol={self.tol}, maxiter={self.maxiter})"


FACTOR_BYTES = {2: 320.0, 3: 210.0}
"""Bytes of a MUMPS LU factorisation of the step Jacobian per n·log(n) DOFs in 2D and per
n^(4/3) in 3D (nested dissection's fill), fitted to the process peaks recorded on the 2D reference
plate and the 3D block (docs/measurements.md, section ngcontact/solve/linalg/petsc_iterative.py;
docs/cluster.md)."""
FACTOR_SHARE = 0.5
"""The share of a node's physical memory that a fallback factorisation may take."""


def factorisation_fits(ndof, dim, mesh):
    """Whether a MUMPS LU of a step Jacobian of ``ndof`` DOFs in ``dim`` D is expected
    (``FACTOR_BYTES``) to fit in ``FACTOR_SHARE`` of the node's physical memory
    (``checks.node_memory``; under MPI every rank's share of its node's is compared with its
    share of the factorisation). The machine's size, not the memory free at the moment: the
    choice, and so the run, must not depend on what else the machine is doing (an earlier
    version read MemAvailable). A factorisation that does not fit, the fallback of a GMRES that
    had not converged, is killed for lack of memory instead of failing with a reason
    (docs/measurements.md, section ngcontact/solve/linalg/petsc_iterative.py)."""
    need = FACTOR_BYTES[dim] * (ndof ** (4 / 3) if dim == 3 else ndof * np.log(max(ndof, 2)))
    total = node_memory()
    comm = parallel.comm_of(mesh)
    if comm is None:
        return need <= FACTOR_SHARE * total
    from mpi4py import MPI
    local = comm.Split_type(MPI.COMM_TYPE_SHARED)                 # the ranks of this node
    share = total / local.size
    local.Free()
    return bool(comm.allreduce(need / max(1, comm.size - 1) <= FACTOR_SHARE * share, op=MPI.LAND))
