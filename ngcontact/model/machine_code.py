"""When the Γ3 integrand is compiled to machine code: a rule fitted to measurements, not a clock.

Compiling the integrand of the Γ3 Jacobian (``StepSystem.use_machine_code``: NGSolve's
``Compile(realcompile=True)`` with first derivatives only, on the element boundaries at Γ3)
takes ``COMPILE_S`` once per simulation and saves, at every assembly of the Γ3 Jacobian (one
per Newton iteration), about ``SAVING`` per facet of Γ3. Both are fitted to measurements on the
Hertz scenes and the reference plate and block (interpreted ``Compile()`` against machine code,
per facet of Γ3 and Jacobian assembly, one thread): docs/measurements.md, section
ngcontact/model/machine_code.py.

A simulation compiles when the Newton iterations it expects save more than the compile costs:
``Simulation.run(dt, T)`` expects ``ITERATIONS_PER_STEP`` per nominal step; a simulation stepped
by hand compiles once the iterations it has made would have paid for the compile (the ski-rental
rule: never more than twice the cost of the better of the two choices made in hindsight). A
one-step Hertz solve then never compiles (it paid for the compile before), a long run of the 3D
block compiles at once.
"""
import os
import shutil
import sys
import sysconfig
import warnings

COMPILE_S = 8.0
"""Seconds to compile the Γ3 Jacobian's integrand (fitted to measurements: docs/measurements.md, section
ngcontact/model/machine_code.py)."""
SAVING = {(2, False): 1e-4, (2, True): 5e-4, (3, False): 6e-4, (3, True): 2.5e-3}
"""Seconds saved per facet of Γ3 and Newton iteration, by (dimension, whether φ is solved)."""
ITERATIONS_PER_STEP = 2
"""Newton iterations a nominal step of ``run`` is expected to take (fitted to the demo's run:
docs/measurements.md, section ngcontact/model/machine_code.py)."""


class MachineCode:
    """The rule for one simulation's ``system`` (a StepSystem with Γ3 terms) with ``facets``
    facets of Γ3 in ``dim`` D; ``electric``: whether φ is solved."""

    def __init__(self, system, facets, dim, electric):
        self.system = system
        self.saving = facets * SAVING[dim, bool(electric)]
        self.spent = 0.0                         # s the interpreted assemblies have cost beyond machine code

    def expect(self, iterations):
        """A run of about ``iterations`` Newton iterations begins: compile now if they pay for it."""
        if self.saving * iterations > COMPILE_S:
            self.system.use_machine_code()

    def account(self, iterations):
        """A step took ``iterations`` Newton iterations: compile once the sum would have paid."""
        self.spent += self.saving * iterations
        if self.spent > COMPILE_S:
            self.system.use_machine_code()


BULK_COMPILED_FROM = 130_000
"""Volume elements (the process's part of the mesh) from which the bulk preconditioner forms'
integrand (``forms.preconditioner_forms``, ``petsc_iterative``) is compiled to machine code
when ``realcompile`` is None: from there one assembly saves more than the compile costs (fitted
to measurements on the 3D block P1, one thread: docs/measurements.md, section
ngcontact/model/machine_code.py)."""


def compile_bulk(realcompile, elements):
    """Whether to compile a bulk integrand assembled on ``elements`` volume elements:
    ``realcompile`` if given (True/False), else from ``BULK_COMPILED_FROM`` elements."""
    return bool(realcompile) if realcompile is not None else elements >= BULK_COMPILED_FROM


def find_compiler():
    """Put the directory of this NGSolve's compiler wrapper ``ngscxx`` first on PATH when the
    ``ngscxx`` PATH finds is another one or none; returns that directory (None if there is no
    wrapper beside this Python). NGSolve installs the wrapper beside the interpreter
    (``sys.executable``'s directory, or sysconfig's scripts directory) but calls it by name,
    and the wrapper runs ``python3`` from PATH to find the headers: a venv's Python started
    without activating the venv (``/path/venv/bin/python -m ngcontact``) found none and fell
    back to interpreted code at every compile, and under pyenv's shims another version's
    wrapper (with that version's headers) was used."""
    for directory in dict.fromkeys((os.path.dirname(sys.executable), sysconfig.get_path("scripts"))):
        wrapper = directory and shutil.which("ngscxx", path=directory)
        if wrapper:
            found = shutil.which("ngscxx")
            if found is None or not os.path.samefile(found, wrapper):
                os.environ["PATH"] = os.pathsep.join(filter(None, (directory, os.environ.get("PATH"))))
            return directory
    return None


_compiler = []
"""Whether ``find_compiler`` has run (once per process, before the first realcompile)."""


def compiled(cf, realcompile, maxderiv=2):
    """cf.Compile(), to machine code if ``realcompile`` (falls back, with a warning, when
    there is no working C++ compiler; NGSolve's ``ngscxx`` found first, ``find_compiler``);
    ``maxderiv``: the derivatives compiled (1 suffices for a Jacobian by
    ``AssembleLinearization``; the cost of 1 and 2: docs/measurements.md)."""
    if realcompile:
        if not _compiler:
            _compiler.append(find_compiler())
        try:
            return cf.Compile(realcompile=True, maxderiv=maxderiv, wait=True)
        except Exception as err:                               # NGSolve raises a plain Exception
            warnings.warn(f"realcompile failed ({err}); using Compile()", RuntimeWarning)
    return cf.Compile()
