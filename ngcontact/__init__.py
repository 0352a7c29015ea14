"""ngcontact: a piezoelectric Kelvin-Voigt body in frictionless unilateral contact with a
conductive foundation, with adhesion (Guettaf & Touzaline), on NGSolve.

The public API is the names below; ``ngcontact.geometries`` (meshes with named
boundaries), ``ngcontact.scenes`` (ready scenes and manufactured solutions) and
``ngcontact.contact_laws`` (the laws p, R_ν, φ_L, ψ), ``ngcontact.obstacles`` (rigid obstacles:
``Plane``, ``Cylinder``, ``Sphere``, ``SignedDistance``; ``Obstacle``, the protocol of one of
the user's), ``ngcontact.methods`` (the enforcement methods on Γ3: their protocols ``Method``
and ``Enforcement``, and ``boundary_stiffness``, for a method of the user's),
``ngcontact.parallel`` (runs under mpiexec on a distributed mesh) and ``ngcontact.checks``
(checks of user input: ranges, booleans, sizes against the machine's memory),
``ngcontact.petsc_solver`` (MUMPS through PETSc: ``MumpsFactorization`` of an NGSolve matrix,
``available()``), ``ngcontact.meshes`` (nested meshes: a mesh refined with its coarse mesh kept;
a copy refined where marked), ``ngcontact.schemes`` (the time schemes; ``TimeScheme``, the
protocol of one of the user's), ``ngcontact.results`` (a run's directory read back: ``read``),
``ngcontact.estimators`` (a posteriori error estimates of a step), ``ngcontact.adapt`` (adaptive
meshes) and ``ngcontact.laws`` (nonlinear F and A) are public modules too, as names of the
package and as import paths (``from ngcontact.obstacles import Plane``). Each name and module is
imported at its first read (``_NAMES``, ``__getattr__``): ``import ngcontact`` loads none of
them, nor SciPy or PETSc (tests/test_imports.py).

The package is in layers, each a sub-package that says what it owns and what it may import:
``model`` (body, materials, laws, loads, supports, forms), ``gamma3`` (the contact data and
everything on Γ3), ``solve`` (the step system and Newton; ``solve.linalg`` the linear
solvers), ``time`` (schemes and stepping), ``output`` (records, results, ParaView), and above
them ``simulation``, ``adapt``, ``estimators``, ``scenes``, ``studies`` and the command line.
The import paths of earlier releases (``ngcontact.forms``, ``ngcontact.newton``, ...) still
work, each with a ``DeprecationWarning`` naming the path to use and the release that drops it
(``moved.REMOVED_IN``).
"""
import importlib as _importlib
import os as _os
import sys as _sys
import warnings as _warnings

from ngcontact import mpi_launch as _mpi_launch, moved as _moved

if _mpi_launch.launched():                      # before NGSolve loads, if it has not yet
    if "ngsolve" in _sys.modules and "OMP_NUM_THREADS" not in _os.environ:
        _warnings.warn("ngsolve was imported before ngcontact under mpiexec without OMP_NUM_THREADS: every rank "
                       "may start one OpenMP thread per core, which made the solves 8x slower on 2 cores; "
                       "export OMP_NUM_THREADS=1 (docs/cluster.md)", RuntimeWarning, stacklevel=2)
    _mpi_launch.one_thread_per_rank()
    _mpi_launch.yield_when_oversubscribed()

_NAMES = {
    "ngcontact.gamma3.contact": ("Contact",),
    "ngcontact.gamma3.enforcement": ("METHODS", "Nitsche", "NodalConstraint", "Penalty"),
    "ngcontact.model.admissible": ("PhysicsWarning",),
    "ngcontact.model.body": ("Body",),
    "ngcontact.model.loads": ("Loads",),
    "ngcontact.model.materials": ("EPS0", "Material", "academic", "batio3", "pzt5a"),
    "ngcontact.output.records": ("ContactRecord", "History", "StepRecord"),
    "ngcontact.output.webgui": ("save_html",),
    "ngcontact.simulation": ("Simulation",),
    "ngcontact.solve.newton": ("NewtonError",),
    "ngcontact.time.stepping": ("AccuracyWarning", "MIN_DT", "TimeStepWarning"),
}
"""Module -> the public names it gives ``ngcontact``; each module is imported at the first read of
one of its names (PEP 562), so that ``import ngcontact`` loads none of them (nor SciPy, PETSc,
the estimators, ...)."""
_ORIGIN = {name: module for module, names in _NAMES.items() for name in names}

_moved.install()                                # the public modules' and the old import paths (``moved``)

__all__ = ["Body", "Contact", "Nitsche", "Penalty", "NodalConstraint", "Loads", "Material", "Simulation", "History",
           "StepRecord", "ContactRecord", "NewtonError", "PhysicsWarning", "AccuracyWarning", "TimeStepWarning",
           "METHODS", "EPS0", "MIN_DT", "academic", "pzt5a", "batio3", "save_html", "contact_laws", "parallel", "checks", "meshes",
           "schemes", "adapt", "estimators", "laws", "petsc_solver", "obstacles", "methods", "results"]


def __getattr__(name):
    """A public name (``_NAMES``) or module (``ngcontact.adapt``, ``ngcontact.obstacles``, a layer),
    imported at its first read and kept; an old module name: the module, with its
    DeprecationWarning (``moved.attribute``)."""
    if name in _moved.MOVED:
        return _moved.attribute(name)
    if name in _ORIGIN:
        value = getattr(_importlib.import_module(_ORIGIN[name]), name)
    else:
        value = _moved.submodule(__name__, name)
    globals()[name] = value
    return value


def __dir__():
    """The names read so far and every public name."""
    return sorted(set(globals()) | set(__all__))
