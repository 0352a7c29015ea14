"""ngcontact: a piezoelectric Kelvin-Voigt body in frictionless unilateral contact with a
conductive foundation, with adhesion (Guettaf & Touzaline), on NGSolve."""
from .body import Body
from .contact import Contact
from .loads import Loads
from .materials import Material, academic, batio3, pzt5a
from .newton import NewtonError
from .results import History, StepRecord
from .timestepping import Simulation
from .webgui import save_html

__all__ = ["Body", "Contact", "Loads", "Material", "Simulation", "History", "StepRecord", "NewtonError",
           "academic", "pzt5a", "batio3", "save_html"]
