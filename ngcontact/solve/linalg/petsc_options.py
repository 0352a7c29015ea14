"""PETSc's options database (``PETSC_OPTIONS``) as ngcontact's PETSc solvers read it
(``petsc_solver``, ``petsc_iterative``): an option PETSc cannot read, or one that would make a
factorisation something else than MUMPS's, is a ValueError naming ``PETSC_OPTIONS`` and the
option, not a PETSc traceback or a Newton iteration that diverges.

The options reach the solvers by prefix: none for ``solver="mumps"``'s factorisation (e.g.
``-mat_mumps_icntl_4 2``, docs/cluster.md), ``ngcontact_u_``, ``ngcontact_phi_`` and
``ngcontact_gamma3_`` for the parts of ``solver="gamg"``. Options without a prefix meant for a
user's own PETSc solvers reach the factorisation too: ``-pc_type jacobi`` there would turn it
into a preconditioner taken for a solve, so it is refused (``check_factorisation``).

``Simulation(solver={...})`` gives the options in Python, as a PETSc user writes them
(``{"pc_type": "gamg", "pc_gamg_threshold": 0.02}``): ``check`` reads them before any work,
and the solver sets them under the same prefixes while its parts read them
(``given_options``), over ``PETSC_OPTIONS``'s of the same name.
"""
import math
import os
import re
from contextlib import contextmanager
from dataclasses import dataclass

from ngcontact.solve.linalg.petsc_modules import load


def _environment():
    return f"PETSC_OPTIONS = {os.environ.get('PETSC_OPTIONS', '')!r}"


def options_error(error, what):
    """A PETSc error raised while PETSc read its options for ``what`` (its stack passes through
    PetscOptions*) as a ValueError naming ``PETSC_OPTIONS`` and PETSc's reason; None for any other
    error."""
    if "PetscOptions" not in str(error):
        return None
    return ValueError(f"PETSc cannot read its options for {what} ({_reason(error)}); {_environment()}")


def _reason(error):
    """What a PETSc error says, without its stack."""
    text = str(error)
    said = "; ".join(re.sub(r"^\[\d+\]\s*", "", line).strip() for line in text.splitlines()[1:]
                     if "() at " not in line and line.strip())
    return said or text.splitlines()[0]


@contextmanager
def reading_options(what):
    """Turn a PETSc error raised while reading PETSc's options (``setFromOptions``, and MUMPS's
    ``-mat_mumps_*`` at the first factorisation) into ``options_error``'s ValueError."""
    PETSc, _ = load()
    try:
        yield
    except PETSc.Error as error:
        named = options_error(error, what)
        if named is None:
            raise
        raise named from None


def check_factorisation(pc, symmetric, what):
    """Refuse (a ValueError) PETSc options that made the PC ``pc`` of the factorisation ``what``
    something else than MUMPS's LU (or LDLᵀ of a ``symmetric`` matrix): ``-pc_type`` or
    ``-pc_factor_mat_solver_type``; Newton would diverge on a preconditioner taken for a solve."""
    allowed = ("lu", "cholesky") if symmetric else ("lu",)
    kind = pc.getType()
    package = pc.getFactorSolverType() if kind in allowed else None
    if kind not in allowed or package != "mumps":
        made = f"pc_type {kind!r}" if kind not in allowed else f"pc_factor_mat_solver_type {package!r}"
        raise ValueError(f"PETSc's options make the factorisation of {what} {made}: it must stay MUMPS's "
                         f"{' or '.join(allowed)} ({_environment()}; options without a prefix reach it: give your "
                         "own solvers' options a prefix)")


PC_TYPES = {"lu": "an LU factorisation (MUMPS's unless pc_factor_mat_solver_type names another)",
            "cholesky": "an LDLᵀ factorisation (MUMPS's, or 'sparsecholesky'; a symmetric Jacobian only)",
            "gamg": "GMRES with Γ3 MUMPS solves around block GAMG (petsc_iterative)",
            None: "none: the factorisation chosen by the Jacobian's symmetry, as by default"}
"""The ``pc_type`` values ``Simulation(solver={...})`` takes, and what each builds."""
KSP_TYPES = {"lu": ("gmres", "preonly"), "cholesky": ("gmres", "preonly"), "gamg": ("gmres",),
             None: ("gmres", "preonly")}
"""The ``ksp_type`` each ``pc_type`` takes, PETSc's default (gmres: the factorisation kept as
GMRES's preconditioner between Newton iterations) first; "preonly": a factorisation per iteration."""
MUMPS_FAMILIES = ("mat_mumps_icntl_", "mat_mumps_cntl_")
FAMILIES = {"lu": MUMPS_FAMILIES, "cholesky": MUMPS_FAMILIES, None: MUMPS_FAMILIES,
            "gamg": ("pc_gamg_", "pc_mg_", "mg_levels_", "mg_coarse_")}
"""The options each ``pc_type`` passes to PETSc's options database, by the start of their names
(MUMPS's with MUMPS only)."""
TYPES = {"pc_type": str, "ksp_type": str, "pc_factor_mat_solver_type": str, "ksp_rtol": float, "ksp_max_it": int,
         "mat_mumps_icntl_": int, "mat_mumps_cntl_": float, "pc_gamg_threshold": float,
         "pc_gamg_agg_nsmooths": int, "pc_gamg_type": str, "pc_gamg_coarse_eq_limit": int,
         "pc_gamg_process_eq_limit": int, "pc_gamg_aggressive_coarsening": int, "pc_gamg_repartition": bool,
         "pc_gamg_reuse_interpolation": bool, "pc_mg_levels": int, "pc_mg_cycle_type": str,
         "mg_levels_ksp_type": str, "mg_levels_pc_type": str, "mg_levels_ksp_max_it": int}
"""The value types of the options whose type is known (a name ending in "_": the family's);
the others of a family take a string, a number or a bool, as PETSc reads them."""
_KINDS = {str: ("a string", lambda v: isinstance(v, str)),
          int: ("an int", lambda v: isinstance(v, int) and not isinstance(v, bool)),
          float: ("a number", lambda v: isinstance(v, (int, float)) and not isinstance(v, bool)),
          bool: ("a bool", lambda v: isinstance(v, bool)),
          None: ("a string, a number or a bool", lambda v: isinstance(v, (str, int, float)))}


@dataclass(frozen=True)
class SolverOptions:
    """``Simulation(solver={...})``: PETSc options as a PETSc user writes them, checked
    (``check``). ``given``: the options as given (for the run's records); ``pc_type``,
    ``ksp_type``: as given (pc_type None: by the Jacobian's symmetry) or PETSc's default (gmres);
    ``package``: the factorisation's name (``pc_factor_mat_solver_type``; "mumps" for a pc_type
    "lu" or "cholesky" given without it; None for a direct solver chosen by the Jacobian's
    symmetry and for "gamg"); ``database``: the options the preconditioner reads from PETSc's
    options database (``given_options``); ``rtol``, ``max_it``: ``ksp_rtol``, ``ksp_max_it``
    (None if not given)."""

    given: dict
    pc_type: str | None
    ksp_type: str
    package: str | None
    database: dict
    rtol: float | None
    max_it: int | None


def _typed(key, value):
    """``value`` of the option ``key`` checked against ``TYPES`` (a TypeError naming both)."""
    kind = TYPES.get(key) or next((t for k, t in TYPES.items() if k.endswith("_") and key.startswith(k)), None)
    what, fits = _KINDS[kind]
    if not fits(value):
        raise TypeError(f"solver: the PETSc option {key!r} must be {what}, got {value!r} ({type(value).__name__})")
    if isinstance(value, float) and not math.isfinite(value):
        raise ValueError(f"solver: the PETSc option {key!r} must be finite, got {value!r}")


def check(spec, factorisations=("mumps",)):
    """``spec`` (a dict of PETSc options, names without the leading dash) as SolverOptions, or a
    TypeError / ValueError naming the option, its value and what is accepted: ``pc_type`` (see
    ``PC_TYPES``), ``ksp_type`` (``KSP_TYPES``), ``pc_factor_mat_solver_type`` one of
    ``factorisations`` (the direct solvers by name: MUMPS, NGSolve's; with pc_type "cholesky"
    MUMPS's or "sparsecholesky", with "lu" any other), ``ksp_rtol`` in (0, 1) and ``ksp_max_it``
    ≥ 1 (gamg), and the options of ``FAMILIES``. Needs no PETSc: it runs before any work."""
    for key, value in spec.items():
        if not isinstance(key, str):
            raise TypeError(f"solver: a PETSc option's name must be a string without the dash (e.g. 'pc_type'), "
                            f"got {key!r} (= {value!r})")
        if key.startswith("-"):
            raise ValueError(f"solver: write the PETSc option {key!r} without the dash: {key.lstrip('-')!r}")
        _typed(key, value)
    pc_type = spec.get("pc_type")
    if pc_type not in PC_TYPES:
        raise ValueError(f"solver: the PETSc options give 'pc_type' = {pc_type!r}, which is not supported here; "
                         "accepted: " + "; ".join(f"{k!r} ({v})" for k, v in PC_TYPES.items() if k))
    ksp_type = spec.get("ksp_type", KSP_TYPES[pc_type][0])
    if ksp_type not in KSP_TYPES[pc_type]:
        raise ValueError(f"solver: the PETSc option 'ksp_type' = {ksp_type!r} is not supported with pc_type "
                         f"{pc_type!r}; accepted: {', '.join(map(repr, KSP_TYPES[pc_type]))}")
    direct = pc_type != "gamg"
    package = spec.get("pc_factor_mat_solver_type", "mumps" if pc_type in ("lu", "cholesky") else None)
    if direct and package is not None and package not in factorisations:
        raise ValueError(f"solver: the PETSc option 'pc_factor_mat_solver_type' = {package!r} is not supported; "
                         f"accepted: {', '.join(map(repr, factorisations))}")
    if pc_type is not None and package not in (None, "mumps") and (pc_type == "cholesky") != (
            package == "sparsecholesky"):
        raise ValueError(f"solver: the PETSc options 'pc_type' = {pc_type!r} and 'pc_factor_mat_solver_type' = "
                         f"{package!r} disagree: 'sparsecholesky' is NGSolve's LDLᵀ ('cholesky'), the others LU "
                         "('lu')")
    accepted = ("pc_type", "ksp_type") + (("pc_factor_mat_solver_type",) if direct else ("ksp_rtol", "ksp_max_it"))
    families = FAMILIES[pc_type] if not direct or package == "mumps" else ()
    for key, value in spec.items():
        if key not in accepted and not (families and key.startswith(families)):
            raise ValueError(f"solver: the PETSc option {key!r} = {value!r} is not supported with pc_type "
                             f"{pc_type!r}" + (f" and {package!r}" if direct and package else "") + "; accepted: "
                             f"{', '.join(accepted)}" + (f" and the options starting with {', '.join(families)}"
                                                         if families else ""))
        if key.startswith(MUMPS_FAMILIES) and not key.rsplit("_", 1)[1].isdigit():
            raise ValueError(f"solver: the PETSc option {key!r} = {value!r} names no MUMPS parameter "
                             "(mat_mumps_icntl_<n>, mat_mumps_cntl_<n>)")
    rtol, max_it = spec.get("ksp_rtol"), spec.get("ksp_max_it")
    if rtol is not None and not 0 < rtol < 1:
        raise ValueError(f"solver: the PETSc option 'ksp_rtol' = {rtol!r} must lie in (0, 1)")
    if max_it is not None and max_it < 1:
        raise ValueError(f"solver: the PETSc option 'ksp_max_it' = {max_it!r} must be at least 1")
    database = {k: v for k, v in spec.items() if families and k.startswith(families)}
    return SolverOptions(dict(spec), pc_type, ksp_type, package if direct else None, database, rtol, max_it)


@contextmanager
def given_options(prefix, options, what=None):
    """``options`` (names without the dash) in PETSc's options database under ``prefix`` while
    the block reads them (over ``PETSC_OPTIONS``'s of the same name), the database as it was
    afterwards: the options of one Simulation do not reach the PETSc solvers of another. With
    ``what`` (the block sets ``what`` up from its options), a PETSc error in the block, and an
    option that PETSc did not read there (not one of ``what``'s), are a ValueError naming the
    options and PETSc's reason."""
    if not options:
        yield
        return
    PETSc, _ = load()
    database = PETSc.Options()
    names = [prefix + key for key in options]
    before = {name: database.getString(name) or None if database.hasName(name) else False for name in names}
    for name, value in zip(names, options.values()):
        database.setValue(name, value)
    try:
        yield
        unread = [name[len(prefix):] for name in names if what and not database.used(name)]
    except PETSc.Error as error:
        if not what:
            raise
        raise ValueError(f"solver: PETSc stopped in {what} with the options {options} ({_reason(error)}; "
                         f"{_environment()})") from None
    finally:
        for name, value in before.items():
            if value is False:
                database.delValue(name)
            else:
                database.setValue(name, value)
    if unread:
        raise ValueError(f"solver: PETSc did not read the option(s) {', '.join(map(repr, unread))} for {what} "
                         f"(not among its options in PETSc {'.'.join(map(str, PETSc.Sys.getVersion()))})")
