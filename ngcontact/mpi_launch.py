"""Whether this process was started by mpiexec with several ranks, one OpenMP/BLAS thread per
rank, and MPI waits that yield the core when there are more ranks than cores. Read from the
environment only (no NGSolve, no mpi4py), so that ``ngcontact`` can set the variables before
NGSolve and MPI load: the runtimes read them once, when they load. With their defaults (a
thread per core on every rank) 2 ranks on 2 cores spent 8× longer per Newton iteration; with
3 ranks on 2 cores MPICH's busy waits took the cores from the ranks that compute
(docs/cluster.md)."""
import os

SIZE_VARIABLES = ("PMI_SIZE", "OMPI_COMM_WORLD_SIZE", "MPI_LOCALNRANKS")
"""What mpiexec (MPICH, Open MPI, Intel MPI) sets to the number of ranks."""
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")
"""The thread counts of OpenMP and OpenBLAS."""
YIELDING = {"MPIR_CVAR_CH4_PROGRESS_THROTTLE": "1", "MPIR_CVAR_CH4_PROGRESS_THROTTLE_NO_PROGRESS_COUNT": "16"}
"""MPICH's waits sleep (usleep(1)) after 16 polls without progress instead of spinning: with 3
ranks on 2 cores (2D reference plate P2, 30 879 DOFs, 59 Newton iterations, MUMPS) 21.1 -> 16.3 s
with the kept factorisation and GMRES, 13.0 -> 11.7 s factorising at every iteration; on rank 0
alone (which computes nothing) no gain (21.5 s). Other MPI libraries ignore the variables.
Not used: MPIR_CVAR_ENABLE_HEAVY_YIELD=1 (waits sleep in nanosleep): rank 0's CPU time fell
(25.7 -> 14.2 s per step) but GMRES waited on the sleeps (3D block P1, 142 404 DOFs, GAMG, 3
ranks on 2 cores: 38.2 -> 53.8 s per step, GMRES 9.6 -> 29.0 s, also with 10⁵ polls before a
sleep)."""


def launched():
    """True if mpiexec started this process as one of several ranks."""
    return any(os.environ.get(name, "1").isdigit() and int(os.environ.get(name, "1")) > 1
               for name in SIZE_VARIABLES)


def one_thread_per_rank():
    """Set every THREAD_VARIABLES to 1 that the user did not set."""
    for name in THREAD_VARIABLES:
        os.environ.setdefault(name, "1")


def size():
    """The number of ranks mpiexec started (1 without mpiexec), from the environment."""
    for name in SIZE_VARIABLES:
        value = os.environ.get(name, "")
        if value.isdigit():
            return int(value)
    return 1


def yield_when_oversubscribed():
    """Set ``YIELDING`` (unless set) when more ranks run than this machine has cores."""
    if size() > (os.cpu_count() or 1):
        for name, value in YIELDING.items():
            os.environ.setdefault(name, value)
