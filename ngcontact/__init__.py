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
package and as import paths (``from ngcontact.obstacles import Plane``).

The package is in layers, each a sub-package that says what it owns and what it may import:
``model`` (body, materials, laws, loads, supports, forms), ``gamma3`` (the contact data and
everything on Γ3), ``solve`` (the step system and Newton; ``solve.linalg`` the linear
solvers), ``time`` (schemes and stepping), ``output`` (records, results, ParaView), and above
them ``simulation``, ``adapt``, ``estimators``, ``scenes``, ``studies`` and the command line.
The import paths of earlier releases (``ngcontact.forms``, ``ngcontact.newton``, ...) still
work, each with a ``DeprecationWarning`` naming the path to use and the release that drops it
(``moved.REMOVED_IN``).
"""
import os as _os
import sys as _sys
import warnings as _warnings

from ngcontact import mpi_launch as _mpi_launch

if _mpi_launch.launched():                      # before NGSolve loads, if it has not yet
    if "ngsolve" in _sys.modules and "OMP_NUM_THREADS" not in _os.environ:
        _warnings.warn("ngsolve was imported before ngcontact under mpiexec without OMP_NUM_THREADS: every rank "
                       "may start one OpenMP thread per core, which made the solves 8x slower on 2 cores; "
                       "export OMP_NUM_THREADS=1 (docs/cluster.md)", RuntimeWarning, stacklevel=2)
    _mpi_launch.one_thread_per_rank()
    _mpi_launch.yield_when_oversubscribed()

from ngcontact import adapt, checks, estimators, meshes, moved as _moved, parallel  # noqa: E402
from ngcontact.gamma3 import contact_laws, enforcement as methods, obstacles  # noqa: E402
from ngcontact.gamma3.contact import Contact  # noqa: E402
from ngcontact.gamma3.enforcement import METHODS, Nitsche, NodalConstraint, Penalty  # noqa: E402
from ngcontact.model import laws  # noqa: E402
from ngcontact.model.admissible import PhysicsWarning  # noqa: E402
from ngcontact.model.body import Body  # noqa: E402
from ngcontact.model.loads import Loads  # noqa: E402
from ngcontact.model.materials import EPS0, Material, academic, batio3, pzt5a  # noqa: E402
from ngcontact.output import results  # noqa: E402
from ngcontact.output.records import ContactRecord, History, StepRecord  # noqa: E402
from ngcontact.output.webgui import save_html  # noqa: E402
from ngcontact.simulation import Simulation  # noqa: E402
from ngcontact.solve.linalg import petsc_solver  # noqa: E402
from ngcontact.solve.newton import NewtonError  # noqa: E402
from ngcontact.time import schemes  # noqa: E402
from ngcontact.time.stepping import AccuracyWarning, MIN_DT, TimeStepWarning  # noqa: E402

_moved.install()                                # the public modules' and the old import paths (``moved``)
__getattr__ = _moved.attribute

__all__ = ["Body", "Contact", "Nitsche", "Penalty", "NodalConstraint", "Loads", "Material", "Simulation", "History",
           "StepRecord", "ContactRecord", "NewtonError", "PhysicsWarning", "AccuracyWarning", "TimeStepWarning",
           "METHODS", "EPS0", "MIN_DT", "academic", "pzt5a", "batio3", "save_html", "contact_laws", "parallel", "checks", "meshes",
           "schemes", "adapt", "estimators", "laws", "petsc_solver", "obstacles", "methods", "results"]
