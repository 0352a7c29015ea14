"""Which linear solver makes the Newton corrections of a simulation (``Simulation(solver=...)``):
the one place that reads a solver's name; by default chosen by the system's symmetry, size and
dimension.

* iterative (``multigrid.MultigridSolver``, GMRES with Γ3 solves around block multigrid for P1,
  block BDDC for P2 and higher): by default in 3D from ``ITERATIVE_FROM`` DOFs without static
  condensation, for P1 on nested meshes (``Body.hierarchy``); direct factorisations fill in
  like n^(4/3) there.
* on a mesh distributed over MPI ranks: MUMPS (through PETSc: the factorisation spread over the
  ranks) where PETSc is installed, kept as the preconditioner of PETSc's GMRES (``krylov``) by
  the same policy as serially (factorised at every Newton iteration with more ranks than
  cores), else NGSolve's "masterinverse" (the Jacobian gathered and factorised on rank 0) at
  every Newton iteration;
* "mumps" serially: MUMPS's LDLᵀ (symmetric Jacobian) or LU, kept as GMRES's preconditioner
  like the other factorisations;
* else a direct factorisation: kept between Newton iterations as GMRES's preconditioner
  (``linear_solver.KeptFactorization``; of the symmetric part for a non-symmetric Jacobian),
  or made at every iteration (``{"ksp_type": "preonly"}``, and Nitsche's θ = −1, whose skew Γ3
  part a factorisation of the symmetric part does not precondition well, docs/speed.md).

A dict of PETSc options as a PETSc user writes them (``petsc_options.check``) builds the same
solvers: ``pc_type`` "gamg" the solver of ``solver="gamg"``; a factorisation by
``pc_factor_mat_solver_type`` (MUMPS, the default for ``pc_type`` "lu" or "cholesky", or one
of NGSolve's, which need no PETSc; none: by the Jacobian's symmetry), kept as GMRES's
preconditioner for ``ksp_type`` "gmres" (PETSc's default), made at every Newton iteration for
"preonly". The earlier options ``inverse=``, ``iterative=``, ``reuse_factorization=`` still
work, with a DeprecationWarning naming their ``solver=`` (``earlier``).
"""
import warnings
from dataclasses import dataclass

from ngcontact.solve.linalg import petsc_options, petsc_solver, protocol
from ngcontact.solve.linalg.linear_solver import (NAMES, PARALLEL_NAMES, DirectSolver, KeptFactorization,
                                                  factorization_worth)
from ngcontact import parallel
from ngcontact.solve.linalg.multigrid import MultigridSolver, needs_nested_mesh
from ngcontact.solve.linalg.petsc_iterative import GamgSolver

ITERATIVE = ("multigrid", "gamg")
"""The iterative solvers by name: GMRES with Γ3 solves around NGSolve's multigrid on nested
meshes (or BDDC), and around PETSc's GAMG."""
ITERATIVE_FROM = 100_000
"""DOFs from which 3D simulations on nested meshes solve iteratively by default (docs/scale.md)."""


def iterative_by_default(body, condense, distributed=False):
    """The default of ``iterative``: in 3D from ITERATIVE_FROM DOFs without condensation,
    "multigrid" serially on nested meshes (for P1), "gamg" on a distributed mesh where PETSc is
    installed; else False (a factorisation)."""
    if body.dim != 3 or body.ndof < ITERATIVE_FROM or condense:
        return False
    if distributed:
        return "gamg" if petsc_solver.available() else False
    nested = (body.hierarchy is not None and body.hierarchy.refinements >= 1) or not needs_nested_mesh(body)
    return "multigrid" if nested else False


KINDS = ("direct", "iterative")
"""Names of a kind of solver, the choice within it left to the system: "direct" the factorisation
chosen by the Jacobian's symmetry (serially "sparsecholesky" or "umfpack", distributed MUMPS or
"masterinverse"), kept as GMRES's preconditioner; "iterative" GMRES around multigrid (NGSolve's
on nested meshes serially, PETSc's GAMG distributed)."""


def names():
    """The names ``Simulation(solver=...)`` takes: the direct solvers (``linear_solver.NAMES``,
    NGSolve's and MUMPS), the iterative ones (``ITERATIVE``) and the kinds (``KINDS``)."""
    return NAMES + ITERATIVE + KINDS


@dataclass(frozen=True)
class Choice:
    """What ``Simulation(solver=...)`` asks for, checked: ``inverse`` (a factorisation's name, or
    None: by the Jacobian's symmetry), ``iterative`` (None: by size, False, True, or a name of
    ``ITERATIVE``), ``reuse`` (a factorisation kept as GMRES's preconditioner between Newton
    iterations) and ``petsc`` (the ``petsc_options.SolverOptions`` of a dict, or None)."""

    inverse: str | None
    iterative: bool | str | None
    reuse: bool
    petsc: object = None


def earlier(inverse, iterative, reuse_factorization):
    """The ``solver=`` that does what the earlier options ``inverse``, ``iterative`` and
    ``reuse_factorization`` did: a name, a kind or a dict of options."""
    if iterative not in (None, False):
        return iterative if isinstance(iterative, str) else "iterative"
    if reuse_factorization is False:
        return {"ksp_type": "preonly", **({"pc_factor_mat_solver_type": inverse} if inverse else {})}
    return inverse or "direct"


def _earlier_text(inverse, iterative, reuse_factorization):
    """``earlier``'s solver= in words, with where it differs: reuse_factorization=False alone did
    nothing where the system chose an iterative solver (3D from ``ITERATIVE_FROM`` DOFs)."""
    text = f"solver={earlier(inverse, iterative, reuse_factorization)!r}"
    if reuse_factorization is False and inverse is None and iterative is None:
        text += (" where the system factorises; reuse_factorization=False had no effect where it chose an "
                 "iterative solver (3D from 10⁵ DOFs on nested meshes), solver=None there")
    return text


def as_options(spec, inverse, iterative, reuse_factorization):
    """The ``Choice`` of ``Simulation(solver=spec)``, checked before any work: for a name, the
    solver it names (one of ``names()``); for a dict of PETSc options (``petsc_options.check``:
    "gamg", or a factorisation by ``pc_factor_mat_solver_type``, kept for ``ksp_type`` "gmres",
    made at every iteration for "preonly"), with PETSc installed where it needs it
    (``petsc_solver.PetscMissing`` naming ``solver=``); an object must have a ``solve`` method that
    takes Newton's arguments and a ``name`` (``protocol.LinearSolver``; an instance, not its class:
    ``protocol.check_object``). For None, the earlier options as given, with a
    DeprecationWarning naming the ``solver=`` that replaces them (``earlier``). A solver given with
    the earlier options (``inverse``, ``iterative``, ``reuse_factorization=False``) is refused:
    they would contradict."""
    given = inverse is not None or iterative is not None or reuse_factorization is False
    if spec is None:
        if given:
            warnings.warn(f"Simulation: inverse=, iterative= and reuse_factorization= are replaced by solver= "
                          f"(here {_earlier_text(inverse, iterative, reuse_factorization)}); they will be "
                          "removed in the next release", DeprecationWarning, stacklevel=3)
        return Choice(inverse, iterative, bool(reuse_factorization))
    if given:
        raise ValueError("Simulation: give the linear solver by solver= alone, or by the earlier options inverse=, "
                         f"iterative=, reuse_factorization=, not both (solver={spec!r}, inverse={inverse!r}, "
                         f"iterative={iterative!r}, reuse_factorization={reuse_factorization!r})")
    if isinstance(spec, dict):
        options = petsc_options.check(spec, NAMES)
        if options.pc_type == "gamg" or options.package == "mumps":
            petsc_solver.load(f"solver={spec!r}")
        if options.pc_type == "gamg":
            return Choice(None, "gamg", True, options)
        return Choice(options.package, False, options.ksp_type == "gmres", options)
    if isinstance(spec, type) and hasattr(spec, "solve"):
        protocol.check_object(spec)                  # a solver's class: an instance is needed
    if not isinstance(spec, str):
        if not (callable(getattr(spec, "solve", None)) and isinstance(getattr(spec, "name", None), str)):
            raise TypeError(f"solver must be None, a name or an object with a solve() method and a name "
                            f"(ngcontact.solve.linalg.protocol.LinearSolver) or a dict of PETSc options, got "
                            f"{'the class ' + spec.__name__ if isinstance(spec, type) else type(spec).__name__}")
        protocol.check_object(spec)
        return Choice(None, False, True)
    if spec not in names():
        raise ValueError(f"solver must be None, an object with a solve() method (ngcontact.solve.linalg."
                         f"protocol.LinearSolver), a dict of PETSc options or one of "
                         f"{', '.join(map(repr, names()))}; got {spec!r}")
    if spec in KINDS:
        return Choice(None, spec == "iterative", True)
    return Choice(None, spec, True) if spec in ITERATIVE else Choice(spec, False, True)


def resolve(spec, body, contact, system, space, choice, **options):
    """(the Newton corrections' solver, the solver of the potential at t = 0) for
    ``Simulation(solver=spec)`` with its ``Choice`` (``as_options``): an object with the
    ``protocol.LinearSolver`` protocol is used as it is (the potential at t = 0 solved as without
    it); else ``choose`` builds it. ``options`` go to ``choose``."""
    if spec is None or isinstance(spec, (str, dict)):
        return choose(body, contact, system, space, inverse=choice.inverse, iterative=choice.iterative,
                      reuse_factorization=choice.reuse, petsc=choice.petsc, **options)
    return spec, choose(body, contact, system, space, inverse=None, reuse_factorization=True, iterative=False,
                        **options)[1]


def needs_petsc(name):
    """Whether the solver ``name`` runs on PETSc ("mumps", "gamg", a dict of PETSc options;
    "iterative" under mpiexec, which is GAMG there): for the command line's refusals before any
    work."""
    if isinstance(name, dict):
        return True
    return name in petsc_solver.NAMES or name == "gamg" or (name == "iterative" and parallel.world() is not None)


def describe(solver):
    """The ``options.*`` of a run's fingerprint for its solver as used: ``inverse`` (the
    factorisation's name, None for an iterative solver or one of the user's), ``reuse_factorization``
    (kept as GMRES's preconditioner) and ``iterative`` ("multigrid", "gamg" or False); for a solver
    of ``Simulation(solver={...})`` with options that tune it (not those of ``CHOOSING``) also
    ``petsc``, those options (absent otherwise: the same solver by a name, a dict or the earlier
    options has the same fields, so a run resumes with either)."""
    iterative = "multigrid" if isinstance(solver, MultigridSolver) else "gamg" if isinstance(solver, GamgSolver) \
        else False
    kept = isinstance(solver, KeptFactorization)
    direct = getattr(solver, "direct", solver)
    inverse = None if iterative else direct.name if isinstance(direct, DirectSolver) else None
    fields = {"options.inverse": inverse, "options.reuse_factorization": kept, "options.iterative": iterative}
    built = direct if isinstance(direct, DirectSolver) else solver if isinstance(solver, GamgSolver) else None
    tuned = {} if built is None or built.options is None else {
        k: v for k, v in built.options.given.items() if k not in CHOOSING}
    if tuned:
        fields["options.petsc"] = dict(sorted(tuned.items()))
    return fields


CHOOSING = ("pc_type", "ksp_type", "pc_factor_mat_solver_type")
"""The PETSc options that choose the solver (``describe``'s other fields hold what they chose);
the rest tune it and are ``options.petsc``."""


def choose(body, contact, system, space, *, inverse, reuse_factorization, iterative, electric, condense,
           realcompile=None, distributed=False, petsc=None):
    """(the Newton corrections' solver, the solver of the potential at t = 0) for ``body``
    and ``contact`` on the StepSystem ``system`` of the product ``space`` (``realcompile``: of
    the preconditioner forms' integrands; None: GAMG's by the mesh size, the multigrid
    hierarchy's not). ``distributed`` (a mesh over several MPI ranks):
    NGSolve's "masterinverse" at every iteration (``check_simulation``). ``petsc``: the
    ``petsc_options.SolverOptions`` of ``Simulation(solver={...})``, for "mumps" (its ``pc_type``
    chooses LU or LDLᵀ; "cholesky" of a non-symmetric Jacobian is a ValueError) or "gamg"."""
    allowed = NAMES + (PARALLEL_NAMES if distributed else ())
    if inverse is not None and inverse not in allowed:
        raise ValueError(f"inverse must be one of {', '.join(map(repr, allowed))} or None, got {inverse!r}")
    if iterative not in (None, True, False) + ITERATIVE:
        raise ValueError(f"iterative must be None (automatic), True, False, 'multigrid' or 'gamg', got {iterative!r}")
    symmetric = system.weak_form.symmetric                   # (a law's Nitsche term is not)
    if petsc is not None and petsc.pc_type in ("lu", "cholesky"):
        if petsc.pc_type == "cholesky" and not symmetric:
            raise ValueError("solver: the PETSc option 'pc_type' = 'cholesky' (LDLᵀ) needs a symmetric Jacobian; "
                             "this one is not (Contact.symmetric is False, or a material law is nonlinear): "
                             "use 'lu'")
        symmetric = petsc.pc_type == "cholesky"
    if petsc is not None and petsc.pc_type != "gamg" and petsc.package != "mumps":
        petsc = None                             # NGSolve's factorisations read no PETSc options
    if iterative is None:
        iterative = inverse is None and iterative_by_default(body, condense, distributed)
    if iterative is True:
        iterative = "gamg" if distributed else "multigrid"
    if iterative:
        if inverse is not None:
            raise ValueError(f"iterative={iterative!r} solves by GMRES; it takes no inverse= (got {inverse!r})")
        if condense:
            raise ValueError(f"solver={iterative!r} needs condense=False (its preconditioner acts on all DOFs)")
        layer = space.GetDofs(body.region("contact_side")) if contact is not None else None
        if iterative == "gamg":                  # PETSc; distributed or serial
            return (GamgSolver(body, system, layer, realcompile=realcompile, options=petsc),
                    GamgSolver(body, system, layer, realcompile=realcompile, options=petsc))
    if distributed:                              # what cannot run there raised in check_simulation
        name = inverse or ("mumps" if petsc_solver.available() else PARALLEL_NAMES[0])
        sym = symmetric and name == "mumps"
        if name == "mumps" and reuse_factorization and not parallel.oversubscribed():   # PETSc's GMRES, kept MUMPS
            return (KeptFactorization(DirectSolver(name, symmetric=sym, options=petsc),
                                      budget=factorization_worth(body.ndof, body.dim)),
                    DirectSolver(name, symmetric=sym, options=petsc))
        return DirectSolver(name, symmetric=sym, options=petsc), DirectSolver(name, symmetric=sym, options=petsc)
    if iterative:                                # "multigrid": NGSolve's, on nested meshes
        if needs_nested_mesh(body) and body.hierarchy is None:
            raise ValueError("solver='multigrid' needs nested meshes: make the mesh with "
                             "ngcontact.meshes.nested_mesh(ngmesh, refine) (ngcontact.geometries do) or give "
                             "Body(hierarchy=...), or use solver='gamg' (PETSc)")
        newton = MultigridSolver(body, system, layer, electric=electric, realcompile=realcompile is True)
        potential = MultigridSolver(body, system, layer, electric=True, realcompile=realcompile is True,
                                    displacement=False)
        return newton, potential
    name = inverse or ("sparsecholesky" if symmetric else "umfpack")
    skew = contact is not None and contact.enforcement_method.skew_symmetric
    if name == "mumps":                          # LDLᵀ or LU by symmetry; kept as GMRES's preconditioner
        direct, potential = (DirectSolver(name, symmetric=symmetric, options=petsc) for _ in range(2))
        if not reuse_factorization:
            return direct, potential
        return KeptFactorization(direct, budget=factorization_worth(body.ndof, body.dim)), potential
    if not reuse_factorization or (inverse is None and skew):
        return DirectSolver(name), DirectSolver(name)
    budget = factorization_worth(body.ndof, body.dim)
    if inverse is None and not symmetric:       # LDLᵀ of the symmetric part: the skew part lives on Γ3
        return KeptFactorization(DirectSolver("sparsecholesky"), symmetric=True, budget=budget), DirectSolver(name)
    return KeptFactorization(DirectSolver(name), budget=budget), DirectSolver(name)


def check_simulation(mesh, contact, inverse, condense, reuse_factorization, iterative=None):
    """What a Simulation on a distributed mesh cannot do raises a ValueError naming the
    feature: the nodal constraint (``method="active_set"``: scipy saddle point systems of one
    rank), a serial factorisation ``inverse``, ``iterative="multigrid"`` (NGSolve's
    multigrid: NGSolve 6.2.2608 cannot refine a distributed mesh, so it has no nested meshes;
    "iterative" is PETSc's GAMG there). Returns the serial defaults switched off,
    with the reason (``Simulation.parallel_notes``; [] on a serial mesh): without PETSc the
    corrections are solved by NGSolve's "masterinverse" (the Jacobian gathered and factorised
    on rank 0) at every Newton iteration. Static condensation runs distributed as serially
    (NGSolve condenses each rank's elements; the Schur complement is factorised by MUMPS or
    masterinverse)."""
    if not parallel.is_distributed(mesh):
        return []
    method = None if contact is None else contact.enforcement_method
    if method is not None and not method.distributable:
        what, why = method.serial_only
        parallel.serial_only(mesh, f"Contact.method {method.name!r} ({what})", why)
    if inverse is not None and inverse not in ("mumps", "masterinverse"):
        parallel.serial_only(mesh, f"solver={inverse!r}", "use solver='mumps' (PETSc) or 'masterinverse', or "
                             "leave solver=None (MUMPS where PETSc is installed, else NGSolve's 'masterinverse')")
    if iterative == "multigrid":
        parallel.serial_only(mesh, "solver='multigrid' (GMRES with NGSolve's multigrid)", "a distributed mesh "
                             "has no nested meshes (NGSolve 6.2.2608 cannot refine it); use solver='iterative' or "
                             "'gamg' (PETSc's algebraic multigrid)")
    notes = []
    mumps = inverse == "mumps" or (inverse is None and petsc_solver.available())
    if reuse_factorization and not mumps:
        notes.append("reuse_factorization: off (its GMRES works on the rank's numpy arrays); "
                     "the direct solver factorises at every Newton iteration")
    elif reuse_factorization and parallel.oversubscribed():
        notes.append("reuse_factorization: off (more ranks than cores: GMRES's collective operations "
                     "would wait for descheduled ranks); MUMPS factorises at every Newton iteration")
    return notes
