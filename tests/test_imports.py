"""What ``import ngcontact`` loads: none of the heavy modules (SciPy's sparse matrices, SymPy,
Matplotlib, PETSc) nor the studies, the estimators or adapt; every public name still resolves,
its module imported at its first read (a PEP 562 ``__getattr__``). Each check runs in a fresh
interpreter. What is loaded, not how long it takes: ``python -m ngcontact imports`` measures that."""
import json
import os
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).parents[1]
HEAVY = ("scipy.sparse", "sympy", "matplotlib", "petsc4py", "ngsPETSc", "tqdm",
         "ngcontact.studies", "ngcontact.scenes", "ngcontact.estimators", "ngcontact.adapt", "ngcontact.simulation")
"""Modules that ``import ngcontact`` must not load (each is loaded where it is first used)."""


def fresh(code):
    """Run ``code`` in a fresh interpreter that imports this checkout; its last line of stdout as JSON."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=ROOT,
                          timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.splitlines()[-1])


def heavy_after(code):
    """The modules of ``HEAVY`` in ``sys.modules`` after ``code``, in a fresh interpreter."""
    return fresh(f"{code}\nimport json, sys\nprint(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))")


def test_import_ngcontact_loads_no_heavy_module():
    assert heavy_after("import ngcontact") == []
    assert heavy_after("import ngsolve, ngcontact\nngcontact.Contact, ngcontact.Body, ngcontact.schemes") == []


def test_a_public_name_loads_its_module_at_its_first_read():
    loaded = set(heavy_after("import ngcontact\nngcontact.adapt.solve"))
    assert {"ngcontact.estimators", "ngcontact.adapt"} <= loaded and "scipy.sparse" not in loaded   # (at an estimate)
    assert "ngcontact.simulation" in heavy_after("from ngcontact import Simulation")


def test_every_public_name_resolves():
    """Each name of ``__all__`` is in ``dir(ngcontact)``, an attribute and importable by name;
    a layer's module is an attribute of its layer without an import of it."""
    missing = fresh("""
import json, ngcontact
missing = [name for name in ngcontact.__all__ if name not in dir(ngcontact)]
for name in ngcontact.__all__:
    try:
        getattr(ngcontact, name)
        exec(f"from ngcontact import {name}", {})
    except Exception as error:
        missing.append(f"{name}: {type(error).__name__}: {error}")
if not ngcontact.solve.linalg.solver_choice.ITERATIVE:
    missing.append("ngcontact.solve.linalg.solver_choice")
print(json.dumps(missing))
""")
    assert missing == []
