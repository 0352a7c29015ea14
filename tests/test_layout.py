"""The shape of the package: layers that import only downwards, one way for the data to flow,
enforcement methods as siblings behind one protocol, and geometries shipped inside ngcontact.

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
from ngcontact.gamma3 import enforcement

ROOT = pathlib.Path(__file__).parents[1]
PACKAGE = ROOT / "ngcontact"
TOP = ("scenes", "studies", "demo", "cli", "__main__", "geometries")
PUBLIC_MODULES = ("ngcontact.scenes", "ngcontact.geometries", "ngcontact.output.progress", "ngcontact.studies")


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


def imports(name, path, source=None):
    """The absolute names a module imports (relative imports resolved), with the names taken
    from each (None for a plain ``import``); every import statement, at the top or inside a
    function. ``source``: the module's text instead of the file's."""
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    result = []
    for node in ast.walk(ast.parse(path.read_text() if source is None else source)):
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


FOUNDATION = ("ngcontact.parallel", "ngcontact.checks", "ngcontact.meshes", "ngcontact.mpi_launch", "ngcontact.moved")
"""Modules every layer may import."""
LAYERS = ("ngcontact.model", "ngcontact.gamma3", "ngcontact.solve.linalg", "ngcontact.solve", "ngcontact.time",
          "ngcontact.output")
"""The layers from the bottom up: each imports the foundation and the layers below it, never one above
(the rest of the package, ``simulation`` and what uses it, sits on top)."""


def rank(name):
    """0 for the foundation, 1 + the layer's index for a layer's module, len(LAYERS) + 1 above."""
    if name in FOUNDATION:
        return 0
    found = [i for i, prefix in enumerate(LAYERS) if name == prefix or name.startswith(prefix + ".")]
    return 1 + max(found) if found else len(LAYERS) + 1      # (solve.linalg before solve: the longer wins)


def targets(target, names):
    """The package modules an import statement reaches: ``from ngcontact import parallel`` reaches
    ngcontact.parallel; ``import ngcontact`` the package's face (the top)."""
    if target == "ngcontact":
        return [f"ngcontact.{n}" for n in names] if names else ["ngcontact"]
    return [target] if target.startswith("ngcontact.") else []


def test_at_most_15_modules_at_the_top_level():
    top = sorted(p.name for p in PACKAGE.glob("*.py"))
    assert len(top) <= 15, top


def test_every_layer_imports_only_the_foundation_and_the_layers_below():
    wrong = []
    for name, path in modules():
        if not name.startswith("ngcontact.") or rank(name) > len(LAYERS):
            continue
        for target, names in imports(name, path):
            for module in targets(target, names):
                if rank(module) > rank(name):
                    wrong.append(f"{name} imports {module}")
    assert not wrong, "\n".join(wrong)


def import_graph(sources):
    """{module: the package modules it imports} of ``sources``, {dotted name: (path, text or None
    for the file's)}: an import of a name of a module reaches the module itself (``from
    ngcontact.x import y`` reaches ngcontact.x.y where that is a module, else ngcontact.x), old
    and public paths (``ngcontact.obstacles``) the module they stand for."""
    from ngcontact.moved import new_name
    graph = {}
    for name, (path, source) in sources.items():
        reached = set()
        for target, names in imports(name, path, source):
            if target != "ngcontact" and not target.startswith("ngcontact."):
                continue
            target = new_name(target) or target
            for module in [target] if names is None else [new_name(f"{target}.{n}") or f"{target}.{n}" for n in names]:
                reached.add(module if module in sources else target)
        graph[name] = sorted(reached & set(sources) - {name})
    return graph


def import_cycles(graph):
    """The import cycles of ``graph`` ({module: modules it imports}) a depth-first search meets,
    each as the modules along it in import order (one within a cycle met before is not repeated)."""
    cycles, done = [], set()
    for start in sorted(graph):
        if start in done:
            continue
        path, on_path, stack = [], {}, [(start, iter(graph[start]))]
        path.append(start)
        on_path[start] = 0
        while stack:
            node, following = stack[-1]
            step = next(following, None)
            if step is None:
                stack.pop()
                path.pop()
                del on_path[node]
                done.add(node)
            elif step in on_path:
                cycle = path[on_path[step]:]
                if not any(set(cycle) <= set(c) for c in cycles):
                    cycles.append(cycle)
            elif step not in done:
                on_path[step] = len(path)
                path.append(step)
                stack.append((step, iter(graph[step])))
    return cycles


PETSC_BEFORE = {
    "ngcontact.solve.linalg.petsc_options": "def reading_options(what):\n"
                                            "    from ngcontact.solve.linalg.petsc_solver import load\n",
    "ngcontact.solve.linalg.petsc_solver": "from ngcontact.solve.linalg.petsc_options import reading_options\n"}
"""How petsc_options and petsc_solver imported each other, one of them inside a function."""


def test_no_import_cycle_among_the_modules():
    """No module of the package imports, directly or through others, a module that imports it:
    imports go one way, also those inside functions (which Python resolves late and so let a
    cycle run). The rule finds the cycle petsc_options and petsc_solver once made."""
    sources = {name: (path, None) for name, path in modules()}
    cycles = import_cycles(import_graph(sources))
    assert not cycles, "\n".join(" -> ".join(c + c[:1]) for c in cycles)
    before = dict(sources, **{name: (PACKAGE / "solve" / "linalg" / f"{name.rsplit('.', 1)[1]}.py", text)
                              for name, text in PETSC_BEFORE.items()})
    assert [set(c) for c in import_cycles(import_graph(before))] == [set(PETSC_BEFORE)]
    assert import_cycles({"a": ["b"], "b": ["c"], "c": ["a"], "d": ["a"]}) == [["a", "b", "c"]]


def test_each_layer_says_what_it_owns_and_what_it_may_import():
    for layer_name in LAYERS:
        doc = __import__(layer_name, fromlist=["*"]).__doc__ or ""
        assert "May import" in doc or "may import" in doc.lower(), layer_name


def test_petsc_is_imported_by_the_linear_algebra_layer_only():
    wrong = [f"{name} imports {target}" for name, path in modules() if not name.startswith("ngcontact.solve.linalg")
             for target, _ in imports(name, path) if target and target.split(".")[0] in ("petsc4py", "ngsPETSc")]
    assert not wrong, wrong


def test_the_old_and_public_import_paths_give_the_modules_of_the_layers():
    """``ngcontact.forms`` and the like (the paths before the layers, deprecated: tests/test_moved.py)
    and the public modules (``ngcontact.obstacles``, ...) are the same module objects."""
    import importlib
    import warnings
    from ngcontact.moved import MOVED, PUBLIC
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        for old, new in {**MOVED, **PUBLIC}.items():
            assert importlib.import_module(f"ngcontact.{old}") is importlib.import_module(f"ngcontact.{new}"), old
        from ngcontact.enforcement.nitsche import Nitsche             # (deprecated paths, on purpose)
        newton = importlib.import_module("ngcontact.newton")          # (deprecated)
    from ngcontact.schemes.bdf2 import BDF2
    assert Nitsche is ngc.Nitsche and BDF2 is ngc.schemes.BDF2
    assert newton.__name__ == newton.__spec__.name == "ngcontact.solve.newton"
    assert {name: getattr(ngc, name) for name in PUBLIC} == {name: importlib.import_module(f"ngcontact.{new}")
                                                             for name, new in PUBLIC.items()}
    assert set(PUBLIC) <= set(ngc.__all__)


def test_the_public_api_is_typed():
    """Every parameter of the public constructors and of Simulation's public methods is annotated,
    and the annotations resolve (``typing.get_type_hints``); Contact and Loads are dataclasses."""
    import dataclasses
    import typing
    from ngcontact.solve.linalg.protocol import LinearSolver
    callables = [ngc.Body.__init__, ngc.Simulation.__init__] + [
        getattr(ngc.Simulation, name) for name in ("step", "advance", "run", "resume", "state", "jacobian")]
    for function in callables:
        hints = typing.get_type_hints(function)
        parameters = [p for p in inspect.signature(function).parameters.values()
                      if p.name != "self" and p.kind is not p.VAR_KEYWORD]
        assert {p.name for p in parameters} <= set(hints) and "return" in hints, function.__qualname__
    assert dataclasses.is_dataclass(ngc.Contact) and dataclasses.is_dataclass(ngc.Loads)
    assert typing.get_type_hints(LinearSolver.solve)["return"] is type(None)
    assert typing.get_type_hints(ngc.Simulation.__init__)["solver"] == str | dict | LinearSolver | None


def test_every_package_is_installed():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    listed = set(config["tool"]["setuptools"]["packages"])
    found = {".".join(path.parent.relative_to(ROOT).parts) for path in PACKAGE.rglob("__init__.py")}
    found |= {"ngcontact.geometries"}
    assert listed == found, (found - listed, listed - found)


def test_every_enforcement_module_is_one_registered_method():
    """One module per method: one method class listed in METHODS with the ``Method`` protocol,
    whose ``build`` makes its Γ3 expressions (the ``Enforcement`` protocol; ``newton_hook`` is
    set per instance); no inheritance between methods."""
    protocol = set(enforcement.Method.__annotations__) | {"contact_fields", "stiffness_factors", "flags", "build",
                                                          "from_contact"}
    expressions = {"signorini", "multiplier", "active", "contact_distance"}
    registered = set(enforcement.METHODS.values())
    for path in sorted((PACKAGE / "gamma3" / "enforcement").glob("*.py")):
        if path.name == "__init__.py":
            continue
        module = __import__(f"ngcontact.gamma3.enforcement.{path.stem}", fromlist=["*"])
        classes = [cls for _, cls in inspect.getmembers(module, inspect.isclass) if cls.__module__ == module.__name__]
        methods = [cls for cls in classes if cls in registered]
        assert len(methods) == 1, path.name
        (method,) = methods
        assert protocol <= set(dir(method)), (path.name, protocol - set(dir(method)))
        assert method.__bases__ == (object,), f"{method.__name__} inherits from {method.__bases__}"
        assert enforcement.METHODS[method.name] is method
        assert any(expressions <= set(dir(cls)) for cls in classes), (path.name, "no class of Γ3 expressions")
    assert len(registered) == len(list((PACKAGE / "gamma3" / "enforcement").glob("*.py"))) - 1


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
        if (PACKAGE / "gamma3" / "enforcement") in path.parents:
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


def test_layout_table_matches_the_tree():
    """Every path in the layout table (docs/layout.md) exists, and every module and folder of the
    package is in it."""
    text = (ROOT / "docs" / "layout.md").read_text()
    table = text[text.index("| path | contents |"):]
    listed = {cell.strip("`") for line in table.splitlines()[2:] if line.startswith("| `")
              for cell in [line.split("|")[1].strip()]}
    assert listed and all((ROOT / path).exists() for path in listed), [p for p in listed if not (ROOT / p).exists()]
    entries = {f"ngcontact/{p.name}" + ("/" if p.is_dir() else "") for p in PACKAGE.iterdir()
               if p.name not in ("__init__.py", "__main__.py", "__pycache__")}
    entries.discard("ngcontact/geometries/")                     # the link to geometries/
    assert entries <= listed, sorted(entries - listed)


BELOW_SIMULATION = LAYERS + ("ngcontact.arguments", "ngcontact.estimators")
"""What Simulation hands parts or its ``steps`` (``time.step.Step``) to, never itself."""


def test_no_module_below_simulation_takes_the_simulation():
    """No parameter named ``sim``/``simulation`` and no import of ``ngcontact.simulation`` below it:
    they receive a ``Step``, its parts or plain data."""
    wrong = []
    for name, path in modules():
        if not name.startswith(BELOW_SIMULATION):
            continue
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.Lambda)):
                arguments = node.args.posonlyargs + node.args.args + node.args.kwonlyargs
                wrong += [f"{name}: {getattr(node, 'name', 'lambda')}({a.arg})" for a in arguments
                          if a.arg in ("sim", "simulation") and not (name.startswith("ngcontact.estimators")
                                                                      and getattr(node, "name", "") in PUBLIC_ENTRY)]
        wrong += [f"{name} imports {target}" for target, _ in imports(name, path) if target == "ngcontact.simulation"
                  or target == "ngcontact" and "simulation" in (_ or [])]
    assert not wrong, "\n".join(wrong)


PUBLIC_ENTRY = ("__init__", "check")
"""The estimator's documented entry ``EquilibratedEstimator(sim)``: it takes the simulation's ``steps``."""


MEASURED_UNIT = r"\d(?:[.,]\d+)?\s?(?:%|ms|µs|s|DOFs?|×)(?!\w)"
MEASURED_VERB = r"\b(?:took|takes?|saves?|saved|faster|slower|cheaper|gave|measured|speed-?ups?)\b"
MEASUREMENT = re.compile(rf"{MEASURED_VERB}[^.;:]{{0,80}}?{MEASURED_UNIT}|{MEASURED_UNIT}[^.;:]{{0,80}}?{MEASURED_VERB}"
                         rf"|{MEASURED_UNIT}\s*(?:against|instead of|->|→)\s*~?\d"     # a before and an after
                         r"|\d{1,3}(?:[  ]\d{3})+\s?DOFs"                              # a run's DOFs: 30 879 DOFs
                         r"|\d(?:\.\d+)?\s?µs\b", re.IGNORECASE)
"""A number with a unit near a verb of measuring, a before-and-after, a run's DOF count or a
timing in µs: what a run measured, which belongs in docs/ (docs/measurements.md), not a docstring."""


def test_docstrings_say_what_and_why_not_what_a_run_measured():
    """No docstring of the package quotes a measurement (the check fails on 57 passages of the
    docstrings before they moved to docs/measurements.md, e.g. "It saves 3-8 % of the
    iterations of the reference run", "0.30 s against 0.28–0.39 s", "30 879 DOFs")."""
    found = []
    for name, path in modules():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant) and isinstance(node.value.value, str):
                found += [f"{name}:{node.lineno}: ...{m.group(0)}..."
                          for m in MEASUREMENT.finditer(" ".join(node.value.value.split()))]
    assert not found, "\n".join(found)
    assert MEASUREMENT.search("It saves 3-8 % of the iterations of the reference run at dt = 2.5 ms")
    assert MEASUREMENT.search("(Hertz P2, 14 298 DOFs, 28 iterations: 0.30 s against 0.28–0.39 s)")
    assert not MEASUREMENT.search("dt : nominal time step, s; at most 0.5 s / steps (free DOFs only)")


INTERNALS = ("newton", "system")
"""A Simulation's parts a test or study reads only through its public records and counters."""
TESTS = ROOT / "tests"


def internal_reads(path):
    """(function, line, text) of each ``X.newton`` / ``X.system`` in the file at ``path``: the
    function is the top-level function or class it is in ("" at module level). ``self.newton``
    (an object's own part, e.g. a scheme of the test's) and a chain rooted at an imported name
    (``os.system``, ``ngcontact.solve.newton``) are not a Simulation's."""
    tree = ast.parse(path.read_text())
    imported = {(alias.asname or alias.name).split(".")[0] for node in ast.walk(tree)
                if isinstance(node, (ast.Import, ast.ImportFrom)) for alias in node.names}
    found = []
    for top in tree.body:
        where = getattr(top, "name", "")
        for node in ast.walk(top):
            if not (isinstance(node, ast.Attribute) and node.attr in INTERNALS):
                continue
            root = node.value
            while isinstance(root, (ast.Attribute, ast.Call, ast.Subscript)):
                root = root.func if isinstance(root, ast.Call) else root.value
            if isinstance(root, ast.Name) and (root.id == "self" or root.id in imported):
                continue
            found.append((where, node.lineno, ast.unparse(node)))
    return found


INTERNALS_ALLOWED = {
    # unit tests of the layer they reach
    ("tests/test_step.py", "test_failed_step_leaves_the_state_bitwise_and_the_retry_matches"):
        "Newton's maxit lowered between steps to make one step fail and the retry succeed",
    ("tests/test_step.py", "test_interrupted_step_is_rolled_back"): "the step system's Apply interrupted mid-step",
    ("tests/test_step.py", "test_kept_factorisation_solves_by_gmres_and_refactorises_when_it_pays"):
        "the kept factorisation driven on the step system's own matrix",
    ("tests/test_step.py", "test_factorisation_is_updated_in_place"): "a factorisation of the step system's matrix",
    ("tests/test_step.py", "test_gmres_that_does_not_converge_falls_back_to_a_fresh_factorisation"):
        "GMRES driven on the step system's matrix",
    ("tests/test_step.py", "test_eisenstat_walker_forcing_asks_for_no_more_than_the_contraction_can_use"):
        "Newton's forcing read on its own solver",
    ("tests/test_step.py", "test_a_failed_solve_keeps_the_linear_solvers_history"):
        "Newton's maxit lowered to make a solve fail",
    ("tests/test_certified.py", "_verdict"): "the stopping rule applied to Newton's own residual and norm",
    ("tests/test_certified.py", "test_a_wrong_state_fails_the_test_at_any_scale"): "the stopping rule at set states",
    ("tests/test_certified.py", "test_the_scale_comes_from_loads_and_bulk_forces_not_from_the_contact_terms"):
        "the step system's force scale in Newton's norm",
    ("tests/test_certified.py", "test_a_perturbed_rigid_motion_is_refused"): "the round-off floor on Newton's free DOFs",
    ("tests/test_scales.py", "_field_residuals"): "the step system's residual in Newton's block norms",
    ("tests/test_petsc.py", "test_a_fallback_factorisation_that_would_not_fit_is_not_made"):
        "GAMG's own counters (oversized solves, Γ3 factorisations), which the records do not split",
    ("tests/test_petsc.py", "test_gamg_compiles_its_preconditioner_forms_on_large_meshes"):
        "the GAMG solver's preconditioner forms",
    ("tests/test_petsc.py", "test_gamg_orders_u_node_by_node"): "the GAMG solver's PETSc blocks against the step system's",
    ("tests/test_petsc.py", "test_gamg_preconditioner_follows_the_rate_coefficient"):
        "the GAMG preconditioner against the step system's rate coefficient",
    ("tests/test_petsc.py", "test_gamg_preconditioner_is_the_surface_bulk_surface_product"):
        "the GAMG solver's preconditioner parts",
    ("tests/test_petsc.py", "test_rigid_motions_from_the_vertices_are_the_interpolated_motions"):
        "GAMG's near null space against the step system's stiffness",
    ("tests/test_petsc_options.py", "test_a_gamg_dict_reaches_the_preconditioners_and_no_other_simulation"):
        "PETSc's options read back from the GAMG solver's own KSP objects",
    ("tests/test_multigrid.py", "test_preconditioner_carries_the_gamma3_terms"):
        "the multigrid preconditioner built on the solver's hierarchy and the step system's matrix",
    ("tests/test_contact.py", "test_reduces_to_chouly_hild"): "the step system's residual against a hand-written form",
    ("tests/test_supports.py", "test_a_step_starts_from_the_last_state_away_from_the_supports"):
        "the step system's begin_step on the state",
    ("tests/test_switch_loop.py", "test_the_signorini_points_give_the_contact_part_of_the_jacobian"):
        "the inner loop's rank-one data against the step system's Γ3 Jacobian",
    ("tests/test_switch_loop.py", "test_a_pull_off_takes_a_few_newton_iterations_and_ends_where_plain_newton_does"):
        "the inner loop's count of the points it switched",
    ("tests/test_switch_loop.py", "test_the_switch_loop_is_an_option_of_its_own"): "whether Newton has the inner loop",
    # instruments: a public read would expose mutable internals
    ("tests/test_globalisation.py", "test_a_search_given_up_names_the_laws_that_changed"):
        "the continuation path removed to reach the line search's last resort",
    ("tests/test_globalisation.py", "test_the_path_stops_its_stages_at_their_reduction_and_the_last_at_the_tolerance"):
        "Newton's tries wrapped to see each stage's reduction",
    ("tests/test_speed.py", "test_a_solve_that_starts_touching_cuts_deeper"):
        "the step length's cut set to an earlier one, its touching state read",
    ("tests/test_speed.py", "test_realcompiled_contact_terms_agree"): "machine code switched on mid-run, as its rule does",
    ("tests/distributed_scenes.py", ""): "the PETSc block size of u on each rank (a distributed run's GAMG)",
    ("ngcontact/studies/bench.py", "one_linear_solve"): "times one of Newton's own corrections",
    ("ngcontact/studies/bench.py", "measure"): "a solver's setup time (no solver sets setup_s: the column is 0)",
    ("ngcontact/studies/cluster_case.py", "factorisations"):
        "the step system's Jacobian and Newton's free DOFs factorised by MUMPS and UMFPACK",
    ("ngcontact/studies/stability/electrode_map.py", "_solve"): "the step length's cut of an earlier release set",
    ("tests/test_adapt.py", "test_a_level_compiles_its_jacobian_by_the_iterations_of_the_level_below"):
        "the machine-code rule instrumented: whether its system compiled when the rule was told",
    # not a Simulation's
    ("ngcontact/studies/adaptivity.py", "study"): "a level's count of Newton iterations",
}
"""(file, function) → why it may read a Simulation's ``newton``/``system``: unit tests of the
layer they reach (they build its objects through the Simulation), and instruments that a public
read would have to expose mutable internals for."""


def test_tests_and_studies_read_records_not_newton_or_system():
    """Tests and studies read what a run did through the public records and counters
    (``history``'s StepRecords, ``solver``, ``solver_detail``, ``solver_options``,
    ``realcompile``, ``rescaled_laws``, ``matrix_changes``, ``pieces()``), never a Simulation's
    ``.newton`` or ``.system``, except where ``INTERNALS_ALLOWED`` names the file and function with
    its reason. An AST scan of tests/*.py and ngcontact/studies/ (``internal_reads``; on the tree
    before the public reads existed it found 126 reads)."""
    paths = sorted(TESTS.glob("*.py")) + files("*.py")
    found, used = [], set()
    for path in paths:
        if path.is_relative_to(PACKAGE) and "studies" not in path.relative_to(PACKAGE).parts:
            continue
        name = path.relative_to(ROOT).as_posix()
        for where, line, text in internal_reads(path):
            if (name, where) in INTERNALS_ALLOWED:
                used.add((name, where))
            else:
                found.append(f"{name}:{line} ({where}): {text}")
    assert not found, f"{len(found)} reads of .newton/.system:\n" + "\n".join(found)
    assert used == set(INTERNALS_ALLOWED), f"allowed but unused: {sorted(set(INTERNALS_ALLOWED) - used)}"


# ------------------------------------------------------------------ the kinematics own the representation
DIMENSION_BRANCH = re.compile(r"\b(?:dim|\.dim)\s*(?:[=!]=|[<>]=?)\s*[23]\b")
DIMENSION_BRANCHES_ALLOWED = {
    "ngcontact/model/kinematics.py": "the owner: which kinematics a mesh dimension gives",
    "ngcontact/meshes.py": "mesh topology: a facet is an edge in 2D, a face in 3D",
    "ngcontact/model/laws.py": "a law's 2 × 2 strain is plane strain, whose ε33 = 0 enters |dev ε|",
    "ngcontact/output/paraview.py": "VTK: vectors have 3 components; Γ3's cells are lines in 2D, triangles in 3D",
    "ngcontact/solve/linalg/solver_choice.py": "a solver heuristic: sparse factorisations fill in more in 3D",
    "ngcontact/solve/linalg/linear_solver.py": "a solver heuristic: when a kept factorisation is worth it",
    "ngcontact/solve/linalg/petsc_iterative.py": "a solver heuristic: the memory a factorisation needs",
    "ngcontact/solve/linalg/petsc_blocks.py": "GAMG's near null space: the rigid modes of a VectorH1 space",
    "ngcontact/estimators/goals.py": "a contact edge is a point on a facet in 2D (a curve across facets in 3D)",
}


def _core_files():
    return [path for name, path in modules() if layer(name) == "core"]


def test_only_the_kinematics_branch_on_the_dimension():
    """No module of the core decides a representation by the mesh dimension: the strain, the
    Voigt maps, the measures and the rigid motions come from the body's kinematics
    (``model.kinematics``); ``DIMENSION_BRANCHES_ALLOWED`` names the few that branch for another
    reason, and each of them still does."""
    found = {}
    for path in _core_files():
        hits = [i + 1 for i, line in enumerate(path.read_text().splitlines())
                if DIMENSION_BRANCH.search(line.split("#")[0]) and not line.lstrip().startswith(('"', "'"))]
        if hits:
            found[str(path.relative_to(ROOT))] = hits
    unexpected = {p: lines for p, lines in found.items() if p not in DIMENSION_BRANCHES_ALLOWED}
    assert not unexpected, f"dimension branches outside the kinematics: {unexpected}"
    assert set(found) == set(DIMENSION_BRANCHES_ALLOWED), \
        f"allowed but without a branch: {sorted(set(DIMENSION_BRANCHES_ALLOWED) - set(found))}"


MEASURE = re.compile(r"\b(?:ngs|ngsolve)\.d[sx]\b|from ngsolve import[^\n]*\bd[sx]\b")


def test_measures_are_built_by_the_kinematics():
    """Every ``dx``/``ds`` of the core is built by ``model.kinematics`` (``Kinematics.dx``/``ds``
    with the body's weight, 2π r for a body of revolution; ``mesh_dx``/``mesh_ds`` over the mesh
    as it is): an integral cannot forget the weight."""
    offenders = [str(path.relative_to(ROOT)) for path in _core_files()
                 if path.name != "kinematics.py" and MEASURE.search(path.read_text())]
    assert not offenders, f"measures built outside the kinematics: {offenders}"


GAMMA3_INTEGRANDS = ("adhesion_traction", "conduction_distance", "charge_flux_density", "j_a", "j_e",
                     "contact_terms")


def test_the_gamma3_integrands_live_in_the_gamma3_layer():
    """j_a, j_e, the adhesion traction and the whole Γ3 part of the residual are defined in
    ``ngcontact.gamma3`` only (``gamma3.integrands``), not in the layer below it."""
    where = {}
    for name, path in modules():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef) and node.name in GAMMA3_INTEGRANDS:
                where.setdefault(node.name, []).append(name)
    assert where, "no Γ3 integrand found"
    outside = {f: owners for f, owners in where.items() if any(not o.startswith("ngcontact.gamma3") for o in owners)}
    assert not outside, f"Γ3 integrands outside ngcontact.gamma3: {outside}"
