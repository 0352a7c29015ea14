"""ngcontact: a piezoelectric Kelvin-Voigt body in frictionless unilateral contact with a
conductive foundation, with adhesion (Guettaf & Touzaline), on NGSolve.

The public API is the names below; ``ngcontact.geometries`` (meshes with named
boundaries), ``ngcontact.scenes`` (ready scenes and manufactured solutions) and
``ngcontact.contact_laws`` (the laws p, R_ν, φ_L, ψ), ``ngcontact.parallel`` (runs under
mpiexec on a distributed mesh) and ``ngcontact.checks`` (checks of user input: ranges,
booleans, sizes against the machine's memory), ``ngcontact.meshes`` (nested meshes: a mesh refined
with its coarse mesh kept; a copy refined where marked), ``ngcontact.schemes`` (the time schemes),
``ngcontact.estimators`` (a posteriori error estimates of a step), ``ngcontact.adapt``
(adaptive meshes) and ``ngcontact.laws`` (nonlinear F and A) are public modules too.
"""
from . import adapt, checks, contact_laws, estimators, laws, meshes, parallel, schemes
from .admissible import PhysicsWarning
from .body import Body
from .contact import Contact
from .enforcement import METHODS
from .loads import Loads
from .materials import EPS0, Material, academic, batio3, pzt5a
from .newton import NewtonError
from .records import ContactRecord, History, StepRecord
from .simulation import Simulation
from .stepping import AccuracyWarning
from .webgui import save_html

__all__ = ["Body", "Contact", "Loads", "Material", "Simulation", "History", "StepRecord", "ContactRecord",
           "NewtonError", "PhysicsWarning", "AccuracyWarning", "METHODS", "EPS0", "academic", "pzt5a", "batio3", "save_html", "contact_laws",
           "parallel", "checks", "meshes", "schemes", "adapt", "estimators", "laws"]
