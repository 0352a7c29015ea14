"""The import paths of the releases before the layers (``ngcontact.forms``, ``ngcontact.newton``,
``ngcontact.schemes``, ...): each still imports the module it names, now in its layer.

``MOVED`` maps every module that moved to its place; ``install()`` puts a finder on
``sys.meta_path`` that answers an old path with the module itself (the same object: a
``monkeypatch`` of one is a patch of the other), importing it only when asked.
"""
import importlib
import importlib.abc
import importlib.util
import sys

MOVED = {
    # ngcontact.model
    "admissible": "model.admissible",
    "body": "model.body",
    "electric_part": "model.electric_part",
    "forms": "model.forms",
    "laws": "model.laws",
    "loads": "model.loads",
    "machine_code": "model.machine_code",
    "materials": "model.materials",
    "rigid": "model.rigid",
    "supports": "model.supports",
    "voigt": "model.voigt",
    # ngcontact.gamma3
    "adhesion": "gamma3.adhesion",
    "contact": "gamma3.contact",
    "contact_laws": "gamma3.contact_laws",
    "contact_side": "gamma3.contact_side",
    "enforcement": "gamma3.enforcement",
    "gamma3_terms": "gamma3.terms",
    "obstacles": "gamma3.obstacles",
    "switches": "gamma3.switches",
    # ngcontact.solve
    "continuation": "solve.continuation",
    "cycles": "solve.cycles",
    "inexact": "solve.inexact",
    "law_terms": "solve.law_terms",
    "law_watch": "solve.law_watch",
    "line_search": "solve.line_search",
    "nested": "solve.nested",
    "newton": "solve.newton",
    "starts": "solve.starts",
    "step_length": "solve.step_length",
    "stopping": "solve.stopping",
    "system": "solve.system",
    # ngcontact.solve.linalg
    "gmres": "solve.linalg.gmres",
    "linear_solver": "solve.linalg.linear_solver",
    "matrices": "solve.linalg.matrices",
    "multigrid": "solve.linalg.multigrid",
    "petsc_blocks": "solve.linalg.petsc_blocks",
    "petsc_iterative": "solve.linalg.petsc_iterative",
    "petsc_options": "solve.linalg.petsc_options",
    "petsc_solver": "solve.linalg.petsc_solver",
    "residual_norm": "solve.linalg.residual_norm",
    "solver_choice": "solve.linalg.solver_choice",
    "solver_restart": "solve.linalg.solver_restart",
    # ngcontact.time
    "schemes": "time.schemes",
    "stepping": "time.stepping",
    # ngcontact.output
    "fingerprint": "output.fingerprint",
    "observables": "output.observables",
    "paraview": "output.paraview",
    "progress": "output.progress",
    "records": "output.records",
    "results": "output.results",
    "run_directory": "output.run_directory",
    "webgui": "output.webgui",
}
"""Old module name under ``ngcontact`` -> its path under ``ngcontact`` now (``ngcontact.gamma3``, once
Γ3's build, is the Γ3 layer: its build is ``ngcontact.gamma3.build``)."""


def new_name(fullname):
    """The module's name now for an old ``ngcontact.<name>[.<sub>]``, or None."""
    prefix, _, old = fullname.partition(".")
    head, _, rest = old.partition(".")
    if prefix != "ngcontact" or head not in MOVED:
        return None
    return f"ngcontact.{MOVED[head]}" + (f".{rest}" if rest else "")


class _Finder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """First on ``sys.meta_path``, so that a module under an old package path (``ngcontact.schemes.bdf2``)
    is not loaded a second time from the package's folder."""

    def find_spec(self, fullname, path=None, target=None):
        return importlib.util.spec_from_loader(fullname, self) if new_name(fullname) else None

    def create_module(self, spec):
        module = importlib.import_module(new_name(spec.name))
        spec.loader_state = module.__spec__          # (the import sets __spec__ to the old path's: put back)
        return module

    def exec_module(self, module):
        module.__spec__ = module.__spec__.loader_state


def install():
    """Answer the old paths from now on (once)."""
    if not any(isinstance(finder, _Finder) for finder in sys.meta_path):
        sys.meta_path.insert(0, _Finder())


def attribute(name):
    """``ngcontact.<old name>`` as an attribute (the package's ``__getattr__``)."""
    if name not in MOVED:
        raise AttributeError(f"module 'ngcontact' has no attribute {name!r}")
    return importlib.import_module(f"ngcontact.{MOVED[name]}")
