"""Whether this process was started by mpiexec with several ranks, one OpenMP/BLAS thread per
rank, and MPI waits that yield the core when there are more ranks than cores. Read from the
environment only (no NGSolve, no mpi4py), so that ``ngcontact`` can set the variables before
NGSolve and MPI load: the runtimes read them once, when they load. With their defaults (a
thread per core on every rank) 2 ranks on 2 cores fought over the cores and each Newton iteration
took far longer; with 3 ranks on 2 cores MPICH's busy waits took the cores from the ranks that
compute (docs/cluster.md; docs/measurements.md, section ngcontact/mpi_launch.py)."""
import os

SIZE_VARIABLES = ("PMI_SIZE", "OMPI_COMM_WORLD_SIZE", "MPI_LOCALNRANKS")
"""What mpiexec (MPICH, Open MPI, Intel MPI) sets to the number of ranks."""
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")
"""The thread counts of OpenMP and OpenBLAS."""
YIELDING = {"MPIR_CVAR_CH4_PROGRESS_THROTTLE": "1", "MPIR_CVAR_CH4_PROGRESS_THROTTLE_NO_PROGRESS_COUNT": "16"}
"""MPICH's waits sleep (usleep(1)) after 16 polls without progress instead of spinning: with 3
ranks on 2 cores the ranks that compute get the cores back and a run takes less time, with the
kept factorisation and GMRES as with a factorisation at every iteration; set on rank 0 alone
(which computes nothing) they gain nothing. Other MPI libraries ignore the variables.
Not used: MPIR_CVAR_ENABLE_HEAVY_YIELD=1 (waits sleep in nanosleep): rank 0's CPU time fell but
GMRES waited on the sleeps and the steps took longer, also with 10⁵ polls before a sleep
(docs/measurements.md, section ngcontact/mpi_launch.py)."""


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
