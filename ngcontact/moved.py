"""The module paths that are not folders of the package: the public modules of ``ngcontact``
that live in a layer (``ngcontact.obstacles``, ``ngcontact.schemes``, ...: kept), and the import
paths of the releases before the layers (``ngcontact.forms``, ``ngcontact.newton``, ...:
deprecated, removed in ``REMOVED_IN``).

``PUBLIC`` maps each public module to its place, ``MOVED`` every old path to its place;
``install()`` puts a finder on ``sys.meta_path`` that answers either path with the module itself
(the same object: a ``monkeypatch`` of one is a patch of the other), importing it only when
asked; ``submodule`` reads a module of a package as its attribute, importing it then
(``ngcontact.solve.linalg.solver_choice`` without an import of it). An old path issues a ``DeprecationWarning`` naming the path to use and the release that
drops it, at the user's line: at its first import in a process (``import ngcontact.forms``,
``from ngcontact.forms import ...``), and at each read as an attribute of the package
(``ngcontact.forms``, ``from ngcontact import forms``) until then.
"""
import importlib
import importlib.abc
import importlib.util
import sys
import warnings

REMOVED_IN = "0.3"
"""The release of ngcontact that drops the old import paths of ``MOVED``."""

PUBLIC = {
    "contact_laws": "gamma3.contact_laws",
    "laws": "model.laws",
    "methods": "gamma3.enforcement",
    "obstacles": "gamma3.obstacles",
    "petsc_solver": "solve.linalg.petsc_solver",
    "results": "output.results",
    "schemes": "time.schemes",
}
"""Public module of ``ngcontact`` (a name of ``ngcontact.__all__``) -> its path under ``ngcontact``:
``ngcontact.<name>`` and the paths under it (``ngcontact.schemes.bdf2``) are the module of its
layer, without a warning."""

MOVED = {
    # ngcontact.model
    "admissible": "model.admissible",
    "body": "model.body",
    "electric_part": "model.electric_part",
    "forms": "model.forms",
    "loads": "model.loads",
    "machine_code": "model.machine_code",
    "materials": "model.materials",
    "rigid": "model.rigid",
    "supports": "model.supports",
    "voigt": "model.voigt",
    # ngcontact.gamma3
    "adhesion": "gamma3.adhesion",
    "contact": "gamma3.contact",
    "contact_side": "gamma3.contact_side",
    "enforcement": "gamma3.enforcement",
    "gamma3_terms": "gamma3.terms",
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
    "residual_norm": "solve.linalg.residual_norm",
    "solver_choice": "solve.linalg.solver_choice",
    "solver_restart": "solve.linalg.solver_restart",
    # ngcontact.time
    "stepping": "time.stepping",
    # ngcontact.output
    "fingerprint": "output.fingerprint",
    "observables": "output.observables",
    "paraview": "output.paraview",
    "progress": "output.progress",
    "records": "output.records",
    "run_directory": "output.run_directory",
    "webgui": "output.webgui",
}
"""Old module name under ``ngcontact`` -> its path under ``ngcontact`` now: deprecated, removed in
``REMOVED_IN``. (``ngcontact.gamma3``, once the module of Γ3's build, is the Γ3 layer; its
``build`` is still the function, the module ``ngcontact.gamma3.build``.)"""


def _split(fullname):
    """(head, rest) of ``ngcontact.<head>[.<rest>]`` (rest "" if none), or None."""
    prefix, _, old = fullname.partition(".")
    head, _, rest = old.partition(".")
    return (head, rest) if prefix == "ngcontact" and head else None


def new_name(fullname):
    """The module's name now for an old path or a public module's path ``ngcontact.<name>[.<sub>]``,
    or None."""
    parts = _split(fullname)
    if parts is None or parts[0] not in MOVED and parts[0] not in PUBLIC:
        return None
    head, rest = parts
    return f"ngcontact.{MOVED.get(head) or PUBLIC[head]}" + (f".{rest}" if rest else "")


def deprecated(fullname):
    """Whether ``fullname`` is an old path (one that warns)."""
    parts = _split(fullname)
    return parts is not None and parts[0] in MOVED


def message(fullname):
    """The DeprecationWarning of an old path: what to import instead and when it goes."""
    new = new_name(fullname)
    return (f"{fullname} is deprecated (an import path from before the layers) and will be removed in "
            f"ngcontact {REMOVED_IN}: import {new} instead")


def _caller():
    """The ``stacklevel`` of ``warnings.warn`` called in ``warn`` that names the first frame outside
    this module and outside importlib: the user's import statement or attribute read. (``warn``
    steps over importlib's bootstrap frames itself: only the other frames count.)"""
    frame, level = sys._getframe(2), 1
    while frame is not None:
        code = frame.f_code.co_filename
        if not ("importlib" in code and "_bootstrap" in code):
            level += 1
        name = frame.f_globals.get("__name__", "")
        if name not in (__name__, "ngcontact") and not name.startswith("importlib"):   # (the package's __getattr__)
            break
        frame = frame.f_back
    return level


def warn(fullname):
    """Issue the DeprecationWarning of the old path ``fullname``."""
    warnings.warn(message(fullname), DeprecationWarning, stacklevel=_caller())


class _Finder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """First on ``sys.meta_path``, so that a module under an old or public path (``ngcontact.schemes.bdf2``)
    is not loaded a second time from the package's folder."""

    def find_spec(self, fullname, path=None, target=None):
        return importlib.util.spec_from_loader(fullname, self) if new_name(fullname) else None

    def create_module(self, spec):
        if deprecated(spec.name):
            warn(spec.name)
        module = importlib.import_module(new_name(spec.name))
        spec.loader_state = module.__spec__          # (the import sets __spec__ to the old path's: put back)
        return module

    def exec_module(self, module):
        module.__spec__ = module.__spec__.loader_state


def install():
    """Answer the old and the public paths from now on (once); nothing is imported until asked."""
    if not any(isinstance(finder, _Finder) for finder in sys.meta_path):
        sys.meta_path.insert(0, _Finder())


def submodule(package, name):
    """The module ``<package>.<name>`` as an attribute of ``package`` (a package's PEP 562
    ``__getattr__``): imported at its first read, or AttributeError where there is none."""
    fullname = f"{package}.{name}"
    if not name.startswith("_") and not deprecated(fullname) and importlib.util.find_spec(fullname) is not None:
        return importlib.import_module(fullname)
    raise AttributeError(f"module {package!r} has no attribute {name!r}")


def attribute(name):
    """``ngcontact.<old name>`` as an attribute (the package's ``__getattr__``): the module, with
    the DeprecationWarning of its old path."""
    if name not in MOVED:
        raise AttributeError(f"module 'ngcontact' has no attribute {name!r}")
    warn(f"ngcontact.{name}")
    return importlib.import_module(f"ngcontact.{MOVED[name]}")
