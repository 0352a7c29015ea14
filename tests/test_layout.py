"""The shape of the package: one way for the data to flow, small modules, enforcement methods
as siblings behind one protocol, and geometries shipped inside ngcontact.

* The core (every module outside scenes/, studies/, demo.py, cli.py) imports none of them,
  nor the geometries.
* The studies use the public API (``ngcontact.<name>`` with a name of ``ngcontact.__all__``)
  and the public modules (scenes, geometries, progress) only.
* The CLI imports only the demo and the studies.
"""
import ast
import inspect
import os
import pathlib
import re
import tomllib

import pytest

import ngcontact as ngc
from ngcontact import enforcement

ROOT = pathlib.Path(__file__).parents[1]
PACKAGE = ROOT / "ngcontact"
TOP = ("scenes", "studies", "demo", "cli", "__main__", "geometries")
PUBLIC_MODULES = ("ngcontact.scenes", "ngcontact.geometries", "ngcontact.progress", "ngcontact.studies")


def files(pattern):
    """The files of the package matching ``pattern``, through ngcontact/geometries (a link)."""
    return sorted(pathlib.Path(folder) / name for folder, _, names in os.walk(PACKAGE, followlinks=True)
                  for name in names if pathlib.PurePath(name).match(pattern))


def modules():
    """(dotted name, path) of every module of the package."""
    found = []
    for path in files("*.py"):
        parts = path.relative_to(ROOT).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        found.append((name, path))
    return found


def imports(name, path):
    """The absolute names a module imports (relative imports resolved), with the names taken
    from each (None for a plain ``import``)."""
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    result = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            result += [(alias.name, None) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package.split(".")
            target = ".".join(base[:len(base) - node.level + 1] + ([node.module] if node.module else [])) \
                if node.level else node.module
            result.append((target, [alias.name for alias in node.names]))
    return result


def layer(name):
    parts = name.split(".")
    return parts[1] if len(parts) > 1 and parts[1] in TOP else "core"


def test_core_imports_no_scene_study_demo_or_cli():
    for name, path in modules():
        if layer(name) != "core":
            continue
        for target, names in imports(name, path):
            targets = [target] + [f"{target}.{n}" for n in names or []]
            bad = [t for t in targets if t.startswith("ngcontact.") and layer(t) != "core"]
            assert not bad, f"{name} imports {bad}"
            assert not target.startswith("geometries"), f"{name} imports {target}"


def test_studies_use_the_public_api_and_scenes_only():
    public = set(ngc.__all__)
    for name, path in modules():
        if layer(name) != "studies":
            continue
        for target, names in imports(name, path):
            if target == "ngcontact":
                assert names is None or set(names) <= public, f"{name}: from ngcontact import {names}"
            elif target.startswith("ngcontact."):
                assert target.startswith(PUBLIC_MODULES), f"{name} imports {target}"
        tree = ast.parse(path.read_text())
        used = {node.attr for node in ast.walk(tree) if isinstance(node, ast.Attribute)
                and isinstance(node.value, ast.Name) and node.value.id == "ngc"}
        assert used <= public, f"{name} uses ngc.{sorted(used - public)}"


def test_cli_only_dispatches():
    (path,) = [p for n, p in modules() if n == "ngcontact.cli"]
    targets = {t for t, _ in imports("ngcontact.cli", path) if t.startswith("ngcontact")}
    assert targets <= {"ngcontact", "ngcontact.demo", "ngcontact.studies", "ngcontact.studies.common",
                       "ngcontact.studies.convergence",
                       "ngcontact.studies.stability", "ngcontact.studies.bench"}, targets


def test_no_module_over_400_lines():
    long = {name: n for name, path in modules() if (n := len(path.read_text().splitlines())) > 400}
    assert not long, long


def test_every_enforcement_module_is_one_registered_method():
    """One module per method: one method class listed in METHODS with the ``Method`` protocol,
    whose ``build`` makes its Γ3 expressions (the ``Enforcement`` protocol; ``newton_hook`` is
    set per instance); no inheritance between methods."""
    protocol = set(enforcement.Method.__annotations__) | {"contact_fields", "stiffness_factors", "flags", "build",
                                                          "from_contact"}
    expressions = {"signorini", "multiplier", "active", "contact_distance"}
    registered = set(enforcement.METHODS.values())
    for path in sorted((PACKAGE / "enforcement").glob("*.py")):
        if path.name == "__init__.py":
            continue
        module = __import__(f"ngcontact.enforcement.{path.stem}", fromlist=["*"])
        classes = [cls for _, cls in inspect.getmembers(module, inspect.isclass) if cls.__module__ == module.__name__]
        methods = [cls for cls in classes if cls in registered]
        assert len(methods) == 1, path.name
        (method,) = methods
        assert protocol <= set(dir(method)), (path.name, protocol - set(dir(method)))
        assert method.__bases__ == (object,), f"{method.__name__} inherits from {method.__bases__}"
        assert enforcement.METHODS[method.name] is method
        assert any(expressions <= set(dir(cls)) for cls in classes), (path.name, "no class of Γ3 expressions")
    assert len(registered) == len(list((PACKAGE / "enforcement").glob("*.py"))) - 1


def test_contact_accepts_exactly_the_registered_methods():
    for name, cls in enforcement.METHODS.items():
        contact = ngc.Contact(method=name)
        assert contact.method == name and type(contact.enforcement_method) is cls
        assert ngc.Contact(method=cls()).enforcement_method == contact.enforcement_method
    with pytest.raises(ValueError, match="Contact.method must be one of 'nitsche', 'penalty', 'active_set'"):
        ngc.Contact(method="mortar")


METHOD_NAME_COMPARISON = re.compile(r"""(==|!=|\bin)\s*\(?\s*["'](nitsche|penalty|active_set)["']"""
                                    r"""|["'](nitsche|penalty|active_set)["']\s*(==|!=)""")


def test_no_module_outside_the_methods_compares_a_method_name():
    """What differs between enforcement methods is asked of the method object
    (``enforcement.Method``), never decided by its name."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if (PACKAGE / "enforcement") in path.parents:
            continue
        for number, line in enumerate(path.read_text().splitlines(), 1):
            if METHOD_NAME_COMPARISON.search(line):
                found.append(f"{path.relative_to(PACKAGE)}:{number}: {line.strip()}")
    assert not found, "\n".join(found)


def test_geometries_ship_inside_ngcontact():
    """No top-level ``geometries`` package is installed; ``ngcontact.geometries`` is the
    repository's geometries/ folder."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    packages = config["tool"]["setuptools"]["packages"]
    assert "geometries" not in packages and "ngcontact.geometries" in packages
    from ngcontact.geometries import plate
    assert pathlib.Path(inspect.getfile(plate)).resolve().parent == (ROOT / "geometries").resolve()
    subpackages = {".".join(p.relative_to(ROOT).parts[:-1]) for p in files("__init__.py")}
    assert subpackages == set(packages), "pyproject's package list and the package's folders differ"


def test_docstrings_cite_the_model_page_in_the_repository():
    assert (ROOT / "docs" / "model.md").exists()
    for name, path in modules():
        text = path.read_text()
        assert "model.md" not in text.replace("docs/model.md", ""), f"{name} cites a model.md outside docs/"


def test_readme_layout_table_matches_the_tree():
    """Every path in the README's layout table exists, and every module and folder of the
    package is in it."""
    text = (ROOT / "README.md").read_text()
    table = text[text.index("| path | contents |"):text.index("## Status")]
    listed = {cell.strip("`") for line in table.splitlines()[2:] if line.startswith("| `")
              for cell in [line.split("|")[1].strip()]}
    assert listed and all((ROOT / path).exists() for path in listed), [p for p in listed if not (ROOT / p).exists()]
    entries = {f"ngcontact/{p.name}" + ("/" if p.is_dir() else "") for p in PACKAGE.iterdir()
               if p.name not in ("__init__.py", "__main__.py", "__pycache__")}
    entries.discard("ngcontact/geometries/")                     # the link to geometries/
    assert entries <= listed, sorted(entries - listed)
