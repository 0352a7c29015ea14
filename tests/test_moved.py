"""The import paths: every old path (``ngcontact.moved.MOVED``) still imports its module with a
DeprecationWarning naming the path to use and the release that drops it; every documented path
(README, docs, tutorials, the package's docstrings and messages) is a real module or a name of
``ngcontact`` and imports without one; the package and the tests use no old path.

Imported modules stay in ``sys.modules``, so that an old path warns only at its first import in
a process: the checks of warnings run in a fresh interpreter each.
"""
import ast
import inspect
import json
import os
import pathlib
import re
import subprocess
import sys
import textwrap

import pytest

from ngcontact.moved import MOVED, PUBLIC, REMOVED_IN

ROOT = pathlib.Path(__file__).parents[1]
DOCUMENTS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), *sorted((ROOT / "tutorials").glob("*.ipynb"))]
HISTORY = {("docs/speed.md", "ngcontact.bench")}
"""Paths named as what a module was called once ("when the module was ``ngcontact.bench``")."""


def fresh(code, *options):
    """Run ``code`` in a fresh interpreter (this checkout first on the path, Python's default
    warning filters); its last line of stdout as JSON, and its stderr."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    env.pop("PYTHONWARNINGS", None)
    done = subprocess.run([sys.executable, *options, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                          env=env, cwd=ROOT, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.splitlines()[-1]), done.stderr


def test_the_release_is_after_this_one():
    version = re.search(r'^version = "([\d.]+)"', (ROOT / "pyproject.toml").read_text(), re.M).group(1)
    assert tuple(map(int, REMOVED_IN.split("."))) > tuple(map(int, version.split(".")))[:2]
    assert set(MOVED).isdisjoint(PUBLIC) and len(MOVED) + len(PUBLIC) == 53


@pytest.fixture(scope="module")
def old_paths():
    """A fresh interpreter that imports ``ngcontact.forms`` as a script would (Python's default
    filters), then each old path as a module, from, and as an attribute of the package, recording
    the warnings: (what it saw, its stderr)."""
    return fresh("""
        import ngcontact.forms
        import importlib, json, sys, warnings
        import ngcontact
        from ngcontact.moved import MOVED
        out = {}
        for code in ("from ngcontact.enforcement.nitsche import Nitsche", "ngcontact.rigid",
                     "from ngcontact import stepping", "import ngcontact.solve.newton"):
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                exec(compile(code, "<user>", "exec"))
            out[code] = [True, [(w.category.__name__, str(w.message), w.filename) for w in caught]]
        for old, new in MOVED.items():
            if f"ngcontact.{old}" in sys.modules:       # (forms and enforcement, above)
                continue
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                same = importlib.import_module(f"ngcontact.{old}") is importlib.import_module(f"ngcontact.{new}")
            out[old] = [same, [(w.category.__name__, str(w.message), w.filename) for w in caught]]
        print(json.dumps(out))
    """)


def test_every_old_path_warns_naming_the_new_path_and_the_release(old_paths):
    """Each old path gives the module of its layer and one DeprecationWarning that names the old
    path, the new one and ``REMOVED_IN``, attributed to the line that imported it (the user's, not
    importlib's); a path under an old one warns for both; an attribute read warns too."""
    seen, _ = old_paths
    assert set(seen) >= set(MOVED) - {"forms", "enforcement"}
    for old, new in MOVED.items():
        if old in ("forms", "enforcement"):
            continue
        same, caught = seen[old]
        assert same, old
        assert [c[0] for c in caught] == ["DeprecationWarning"], (old, caught)
        message = caught[0][1]
        assert re.search(rf"ngcontact\.{old}\b.*deprecated.*removed in ngcontact {re.escape(REMOVED_IN)}: "
                         rf"import ngcontact\.{re.escape(new)} instead$", message), message
        assert caught[0][2] == "<string>", (old, caught[0][2])        # the importing line (python -c)
    nitsche = seen["from ngcontact.enforcement.nitsche import Nitsche"][1]
    assert [m for _, m, _ in nitsche] == [
        f"ngcontact.enforcement is deprecated (an import path from before the layers) and will be removed in "
        f"ngcontact {REMOVED_IN}: import ngcontact.gamma3.enforcement instead",
        f"ngcontact.enforcement.nitsche is deprecated (an import path from before the layers) and will be removed "
        f"in ngcontact {REMOVED_IN}: import ngcontact.gamma3.enforcement.nitsche instead"]
    assert {f for _, _, f in nitsche} == {"<user>"}
    rigid = seen["ngcontact.rigid"][1]                       # (an attribute of the package)
    assert len(rigid) == 1 and "import ngcontact.model.rigid instead" in rigid[0][1] and rigid[0][2] == "<user>"
    stepping = seen["from ngcontact import stepping"][1]     # (an attribute read before its first import)
    assert stepping and {m for _, m, _ in stepping} == {
        f"ngcontact.stepping is deprecated (an import path from before the layers) and will be removed in "
        f"ngcontact {REMOVED_IN}: import ngcontact.time.stepping instead"}
    assert seen["import ngcontact.solve.newton"][1] == []    # a new path: silent


def test_a_script_sees_the_warning_under_the_default_filters(old_paths):
    """``import ngcontact.forms`` in a script (``__main__``): Python's default filters show the
    warning (PEP 565), on the script's line."""
    _, stderr = old_paths
    lines = [line for line in stderr.splitlines() if "DeprecationWarning" in line]
    expected = (f"<string>:2: DeprecationWarning: ngcontact.forms is deprecated (an import path from before the "
                f"layers) and will be removed in ngcontact {REMOVED_IN}: import ngcontact.model.forms instead")
    assert lines == [expected], stderr


def imports_of(source):
    """The import statements naming ngcontact in ``source`` (code of a block or cell)."""
    try:
        tree = ast.parse(source)
    except SyntaxError:                     # (a block with ``...`` or shell lines: its import lines)
        lines = [line.strip() for line in source.splitlines() if re.match(r"\s*(from|import)\s+ngcontact\b", line)]
        return [line for line in lines if not line.endswith("(")]
    return [ast.unparse(node) for node in ast.walk(tree) if isinstance(node, (ast.Import, ast.ImportFrom))
            and "ngcontact" in ast.unparse(node)]


def documented():
    """(where, text, code blocks) of the README, the docs and the tutorials."""
    found = []
    for path in DOCUMENTS:
        where = str(path.relative_to(ROOT))
        if path.suffix == ".ipynb":
            cells = json.loads(path.read_text())["cells"]
            text = "\n".join("".join(cell["source"]) for cell in cells)
            blocks = ["".join(cell["source"]) for cell in cells if cell["cell_type"] == "code"]
        else:
            text = path.read_text()
            blocks = re.findall(r"```(?:python|py)?\n(.*?)```", text, re.S)
        found.append((where, text, blocks))
    return found


DOTTED = re.compile(r"\bngcontact(?:\.[A-Za-z_]\w*)+")
ATTRIBUTE = re.compile(r"\bngc\.([A-Za-z_]\w*)")


def mentions():
    """(where, line, path) of every ``ngcontact.a.b`` in the documents and the package's source
    (docstrings, messages), but lines that speak of the deprecated paths themselves."""
    texts = [(where, text) for where, text, _ in documented()]
    texts += [(str(p.relative_to(ROOT)), p.read_text()) for p in sorted((ROOT / "ngcontact").rglob("*.py"))
              if p.name != "moved.py"]
    found = []
    for where, text in texts:
        for line in text.splitlines():
            if re.search(r"deprecated|earlier releases", line):
                continue
            found += [(where, line.strip(), path.rstrip(".")) for path in DOTTED.findall(line)
                      if (where, path) not in HISTORY]
    return found


@pytest.fixture(scope="module")
def clean():
    """A fresh interpreter with DeprecationWarnings as errors that imports every module of the
    package, the public modules by their paths, ``from ngcontact.gamma3 import build``, runs every
    import line of the documents' code and resolves every documented path: what it found."""
    statements = sorted({line for _, _, blocks in documented() for block in blocks for line in imports_of(block)})
    paths = sorted({path for _, _, path in mentions()})
    attributes = sorted({name for _, text, _ in documented() for name in ATTRIBUTE.findall(text)})
    assert "from ngcontact.obstacles import Cylinder" in statements and len(statements) > 10, statements
    assert "ngcontact.obstacles.Plane" in paths and "Simulation" in attributes
    seen, _ = fresh(f"""
        import importlib, inspect, json, pkgutil, sys
        from ngcontact.gamma3.build import Gamma3, gamma3_data      # the module's path first
        from ngcontact.gamma3 import build
        import ngcontact.gamma3.build
        import ngcontact
        from ngcontact.moved import PUBLIC
        out = {{}}
        module = importlib.import_module("ngcontact.gamma3.build")
        out["build"] = [inspect.isfunction(build), build.__module__, inspect.ismodule(module),
                        module is sys.modules["ngcontact.gamma3.build"], module.Gamma3 is Gamma3,
                        module.gamma3_data is gamma3_data]
        names = sorted(m.name for m in pkgutil.walk_packages(ngcontact.__path__, "ngcontact."))
        for name in names:
            importlib.import_module(name)
        import ngcontact.simulation
        out["build"].append(module.build is build is ngcontact.gamma3.build is ngcontact.simulation.build_gamma3)
        out["modules"] = len(names)
        out["public"] = {{}}
        for name, path in PUBLIC.items():
            public = importlib.import_module(f"ngcontact.{{name}}")
            out["public"][name] = public is importlib.import_module(f"ngcontact.{{path}}") is getattr(ngcontact, name)
        from ngcontact.schemes.bdf2 import BDF2
        from ngcontact.obstacles import Plane, Cylinder, Sphere, SignedDistance
        out["public"]["sub"] = BDF2 is ngcontact.schemes.BDF2 and Plane is ngcontact.obstacles.Plane
        for name in ngcontact.__all__:
            getattr(ngcontact, name)
        out["statements"] = []
        for line in {statements!r}:
            try:
                exec(line, {{}})
            except Exception as error:
                out["statements"].append(f"{{line}}: {{type(error).__name__}}: {{error}}")
        out["paths"] = []
        for path in {paths!r}:
            parts = path.split(".")
            try:
                for cut in range(len(parts), 0, -1):
                    try:
                        target = importlib.import_module(".".join(parts[:cut]))
                    except ImportError:
                        continue
                    break
                for part in parts[cut:]:
                    if not hasattr(target, part):
                        out["paths"].append(path)
                        break
                    target = getattr(target, part)
            except DeprecationWarning as warning:
                out["paths"].append(f"{{path}} ({{warning}})")
        out["paths"] += [f"ngc.{{name}}" for name in {attributes!r} if name not in vars(ngcontact)]
        print(json.dumps(out))
    """, "-W", "error::DeprecationWarning")
    return seen


def test_the_package_and_the_public_modules_import_no_old_path(clean):
    """Every module of the package, every public module by its path and as a name of the package
    (``ngcontact.obstacles``, ``from ngcontact.schemes.bdf2 import BDF2``) and every name of
    ``__all__`` import with DeprecationWarnings as errors."""
    assert clean["modules"] > 100 and set(clean["public"]) == set(PUBLIC) | {"sub"}, clean
    assert all(clean["public"].values()), clean["public"]


def test_documented_imports_do_not_warn(clean):
    """Every import line naming ngcontact in the code of the README, docs and tutorials runs with
    DeprecationWarnings as errors."""
    assert not clean["statements"], "\n".join(clean["statements"])


def test_every_documented_path_is_a_real_module_or_a_name_of_ngcontact(clean):
    """Each ``ngcontact.a.b.c`` in the documents and the package resolves, without a warning, to a
    module of the package or a name in one (the longest module prefix imported, the rest read as
    attributes); each ``ngc.X`` in the documents is a name of ``ngcontact``."""
    where = {path: f"{w}: {line}" for w, line, path in mentions()}
    where |= {f"ngc.{name}": w for w, text, _ in documented() for name in ATTRIBUTE.findall(text)}
    assert not clean["paths"], "\n".join(f"{path}: {where.get(path.split()[0], '')}" for path in clean["paths"])


def test_gamma3_build_is_the_function_and_its_module_imports_by_path(clean):
    """``from ngcontact.gamma3 import build`` gives the function (as when Γ3 was one module); the
    module ``ngcontact.gamma3.build`` is imported by its path, by the package and by users, in
    either order."""
    assert clean["build"] == [True, "ngcontact.gamma3.build", True, True, True, True, True]
    from ngcontact.gamma3 import Gamma3, build, gamma3_data
    assert list(inspect.signature(build).parameters) == ["body", "contact", "system", "realcompile"]
    assert Gamma3.__module__ == gamma3_data.__module__ == "ngcontact.gamma3.build"


OLD = "|".join(sorted(MOVED, key=len, reverse=True))
OLD_USE = re.compile(rf"\b(?:ngcontact|ngc)\.(?:{OLD})\b")


@pytest.mark.parametrize("folder", ["ngcontact", "tests"])
def test_the_package_and_the_tests_use_no_old_path(folder):
    """No ``ngcontact.<old>``, ``ngc.<old>`` or ``from ngcontact import <old>`` in the source: the
    imports at run time (inside functions) included, which the import checks above do not reach."""
    found = []
    for path in sorted((ROOT / folder).rglob("*.py")):
        if path.name in ("moved.py", "test_moved.py", "hostile_moved.py"):        # (old paths on purpose)
            continue
        text = path.read_text()
        froms = {node.lineno for node in ast.walk(ast.parse(text)) if isinstance(node, ast.ImportFrom)
                 and node.module == "ngcontact" and {alias.name for alias in node.names} & set(MOVED)} \
            if re.search(r"from\s+ngcontact\s+import", text) else set()
        for number, line in enumerate(text.splitlines(), 1):
            if (number in froms or OLD_USE.search(line)) and not re.search(r"deprecated|earlier releases", line):
                found.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()}")
    assert not found, "\n".join(found)


def test_the_release_named_in_the_layout_page_is_the_constant():
    layout = (ROOT / "docs" / "layout.md").read_text()
    line = next(line for line in layout.splitlines() if line.startswith("| `ngcontact/moved.py`"))
    assert f"removed in {REMOVED_IN})" in line, line
