"""Whether this process was started by mpiexec with several ranks, and one OpenMP/BLAS thread
per rank. Read from the environment only (no NGSolve, no mpi4py), so that ``ngcontact``
can set the threads before NGSolve loads: the runtimes read the variables once, when they
load, and with their default (a thread per core on every rank) 2 ranks on 2 cores spent 8×
longer per Newton iteration (docs/cluster.md)."""
import os

SIZE_VARIABLES = ("PMI_SIZE", "OMPI_COMM_WORLD_SIZE", "MPI_LOCALNRANKS")
"""What mpiexec (MPICH, Open MPI, Intel MPI) sets to the number of ranks."""
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")
"""The thread counts of OpenMP and OpenBLAS."""


def launched():
    """True if mpiexec started this process as one of several ranks."""
    return any(os.environ.get(name, "1").isdigit() and int(os.environ.get(name, "1")) > 1
               for name in SIZE_VARIABLES)


def one_thread_per_rank():
    """Set every THREAD_VARIABLES to 1 that the user did not set."""
    for name in THREAD_VARIABLES:
        os.environ.setdefault(name, "1")
