"""Hostile inputs of class ``moved`` (``tests/test_hostile.py``): the import paths of the releases
before the layers (``ngcontact.moved``).

An old path, however it is reached (``import``, ``import ... as``, ``from ... import``, a module
under it, ``importlib.import_module``, an attribute of the package), gives the module of its
layer with a DeprecationWarning on the user's line that names the old path, the path to use and
the release that drops it (``moved.REMOVED_IN``); a public path (``ngcontact.obstacles``,
``ngcontact.results``, ``ngcontact.schemes.bdf2``) gives its module without one; ``from
ngcontact.gamma3 import build`` is the function, as when Γ3 was one module; a name that never
was is a ModuleNotFoundError or AttributeError naming it. Each case runs its code in a process
forked from the server, which has imported no old path.
"""
import re
import warnings

CLASSES = ("moved",)


def register(h):
    from ngcontact.moved import MOVED, REMOVED_IN

    def run(code):
        """A case's call: ``code`` run as a user's (file "<user>"), what it left in ``value`` and
        the DeprecationWarnings it raised."""
        def call(ctx):
            scope = {}
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                exec(compile(code, "<user>", "exec"), scope)
            found = [w for w in caught if issubclass(w.category, DeprecationWarning)]
            value = scope.get("value")
            return dict(messages="\n".join(dict.fromkeys(str(w.message) for w in found)),
                        files=" ".join(sorted({w.filename for w in found})),
                        name=getattr(value, "__name__", repr(value)), module=getattr(value, "__module__", None),
                        kind=type(value).__name__)
        return call

    def warns(*old, name):
        """One warning (repeated at most) per old path in ``old``, in order, naming it, its new
        path and the release, on the user's line; ``value`` named ``name``."""
        def check(v, references):
            messages = v["messages"].splitlines() if v["messages"] else []
            if len(messages) != len(old):
                return f"{len(messages)} DeprecationWarnings for {', '.join(old)}: {messages}"
            for path, message in zip(old, messages):
                new = "ngcontact." + MOVED[path.split(".")[0]] + path[len(path.split(".")[0]):]
                if not re.fullmatch(rf"ngcontact\.{re.escape(path)} is deprecated .* removed in ngcontact "
                                    rf"{re.escape(REMOVED_IN)}: import {re.escape(new)} instead", message):
                    return f"the warning of ngcontact.{path} does not name {new} and {REMOVED_IN}: {message}"
            if v["files"] != "<user>":
                return f"the warning points at {v['files']}, not at the user's line"
            return None if v["name"] == name else f"gave {v['name']}, not {name}"
        return h.Correct(check)

    def silent(name, kind=None, module=None):
        """No DeprecationWarning; ``value`` named ``name`` (of type ``kind``, from ``module``)."""
        def check(v, references):
            if v["messages"]:
                return f"warned: {v['messages']}"
            got = (v["name"], v["kind"] if kind else None, v["module"] if module else None)
            return None if got == (name, kind, module) else f"gave {got}, not {(name, kind, module)}"
        return h.Correct(check)

    def case(label, code, expect):
        h.case("moved", label, run(code), expect)

    # ------------------------------------------------------------------ old paths: warned, and the module of the layer

    case("import ngcontact.forms", "import ngcontact.forms\nvalue = ngcontact.forms",
         warns("forms", name="ngcontact.model.forms"))
    case("import ngcontact.gamma3_terms as", "import ngcontact.gamma3_terms as value",
         warns("gamma3_terms", name="ngcontact.gamma3.terms"))
    case("from ngcontact.newton import NewtonError",
         "from ngcontact.newton import NewtonError\nimport ngcontact\n"
         "value = ngcontact.solve.newton if NewtonError is ngcontact.NewtonError else None",
         warns("newton", name="ngcontact.solve.newton"))
    case("importlib.import_module('ngcontact.petsc_options')",
         "import importlib\nvalue = importlib.import_module('ngcontact.petsc_options')",
         warns("petsc_options", name="ngcontact.solve.linalg.petsc_options"))
    case("from ngcontact.enforcement.nitsche import Nitsche",
         "from ngcontact.enforcement.nitsche import Nitsche\nimport sys\n"
         "value = sys.modules['ngcontact.enforcement.nitsche']",
         warns("enforcement", "enforcement.nitsche", name="ngcontact.gamma3.enforcement.nitsche"))
    case("ngcontact.materials (an attribute)", "import ngcontact\nvalue = ngcontact.materials",
         warns("materials", name="ngcontact.model.materials"))
    case("from ngcontact import stepping", "from ngcontact import stepping as value",
         warns("stepping", name="ngcontact.time.stepping"))
    case("import ngcontact.webgui, then its new path",
         "import ngcontact.webgui\nimport ngcontact.output.webgui as value",
         warns("webgui", name="ngcontact.output.webgui"))

    # ------------------------------------------------------------------ public paths: silent

    case("from ngcontact.obstacles import Plane", "from ngcontact.obstacles import Plane as value",
         silent("Plane", "type", "ngcontact.gamma3.obstacles"))
    case("import ngcontact.results as", "import ngcontact.results as value", silent("ngcontact.output.results"))
    case("from ngcontact.schemes.bdf2 import BDF2",
         "from ngcontact.schemes.bdf2 import BDF2\nimport ngcontact\n"
         "value = BDF2 if BDF2 is ngcontact.schemes.BDF2 else None",
         silent("BDF2", "type", "ngcontact.time.schemes.bdf2"))
    case("from ngcontact.gamma3 import build", "from ngcontact.gamma3 import build as value",
         silent("build", "function", "ngcontact.gamma3.build"))
    case("from ngcontact.gamma3.build import Gamma3, then gamma3's build",
         "from ngcontact.gamma3.build import Gamma3\nfrom ngcontact.gamma3 import build as value",
         silent("build", "function", "ngcontact.gamma3.build"))

    # ------------------------------------------------------------------ names that never were

    case("import ngcontact.no_such_module", "import ngcontact.no_such_module",
         h.Error("ModuleNotFoundError", r"ngcontact\.no_such_module"))
    case("import ngcontact.forms.no_such_module", "import ngcontact.forms.no_such_module",
         h.Error("ModuleNotFoundError", r"ngcontact\.forms\.no_such_module"))
    case("ngcontact.no_such_name", "import ngcontact\nngcontact.no_such_name",
         h.Error("AttributeError", "no_such_name"))
