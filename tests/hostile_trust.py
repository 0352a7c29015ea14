"""Hostile inputs of the command line that must end in one line (``tests/test_hostile.py``,
class ``cli``): a missing optional engine, a command that would run nothing, and time inputs
far outside the load history a command runs (steps past its end, steps below the smallest
time step, a final time before anything happens, sizes no study can use).

Each case expects ``CliError``: exit status 2 and one line on stderr naming the option, before
any work. The cases of an option that needs PETSc depend on whether PETSc is installed here
(``PETSC``, as the command line decides it: petsc4py and ngsPETSc found, without importing
them; the fork server must not start PETSc): without it the line names the option and the
install line (``petsc_solver.INSTALL``); with it the command completes (exit status 0; the
cluster studies launch runs of their own and are ``slow`` then).
"""
from ngcontact.studies.common import petsc_missing

CLASSES = ()

PETSC = not petsc_missing()
"""Whether the PETSc engine is installed here (found, not imported)."""


def register(h):
    def completed(v, references):
        """The command ran to its end (exit status 0)."""
        if v["code"] != 0:
            lines = [line for line in v["stderr"].splitlines() if line.strip()]
            return f"exit status {v['code']}: {h._line(lines[-1] if lines else 'nothing on stderr')}"
        return None

    def command(arguments, *words, petsc=None, slow=False):
        """A ``cli`` case: one line naming ``words``; if ``petsc`` (the option that needs PETSc),
        without PETSc one line naming it and the install line, with PETSc completed."""
        argv = arguments.split()
        full = argv[:1] + h.CHEAP.get(argv[0], []) + argv[1:]
        if petsc is None:
            expect = h.CliError(*words)
        elif PETSC:
            expect = h.Correct(completed) if not words else h.CliError(*words)
        else:
            expect = h.CliError(petsc, "PETSc", "pip install")
        h.case("cli", arguments, lambda ctx, a=full: h.command_line(a, ctx), expect,
               slow=slow and PETSC and petsc is not None and not words)

    # ------------------------------------------------------------------ an optional engine missing

    command("bench --inverse mumps", petsc="inverse")
    command("bench --solver gamg", petsc="solver")
    command("bench --merge /nonexistent --inverse mumps", "merge")        # --merge runs no solver: not refused
    command("cluster --solvers mumps --realcompile no", petsc="solvers", slow=True)
    command("cluster --solvers gamg masterinverse --realcompile no", petsc="solvers", slow=True)
    command("cluster --factorisations --levels 0", petsc="factorisations", slow=True)
    command("cluster --factorisations --levels 0 --dt 1e300", *(("dt",) if PETSC else ()), petsc="factorisations")
    if not PETSC:                 # as a user sees it: python -m ngcontact, Python's start-up included
        h.cli("bench --inverse mumps", "inverse,PETSc,pip install", process=True)

    # ------------------------------------------------------------------ options that exclude each other
    for arguments in ("bench --inverse umfpack --solver multigrid", "bench --inverse sparsecholesky --solver iterative",
                      "bench --inverse mumps --solver gamg"):
        command(arguments, "inverse", "solver")

    # ------------------------------------------------------------------ commands that would run nothing

    command("cluster --solvers masterinverse", "solvers", "masterinverse", "ranks")      # serial: no rank to gather to
    command("adapt --scene hertz3d --orders 2", "scene", "orders", "hertz3d")
    command("adapt --scene hertz3d hertz3d --orders 3 4", "scene", "orders", "hertz3d")

    # ------------------------------------------------------------------ time inputs outside the load history

    for arguments in ("cluster --dt 1e300", "cluster --dt 0.6", "cluster --dt 1e-300", "cluster --steps 1000000",
                      "cluster --steps 200 --dt 0.005", "bench --dt 1e300", "bench --dt 1", "bench --dt 1e-300",
                      "bench --steps 1000000", "bench --steps 300"):
        command(arguments, "dt")
    for value in ("1e-12", "0.005", "0.6", "1e300", "-1", "nan"):
        command(f"timesteps --T {value}", "T")
    for value in ("3e-5", "1e-6"):
        command(f"timesteps --maxh {value}", "maxh")
    command("convergence --dt-halvings 1 --dt0 1e-300", "dt0")
    command("convergence --dt-halvings 12 --dt0 1e-3", "dt0", "dt[-_]halvings")
