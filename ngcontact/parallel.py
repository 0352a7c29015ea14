"""Distributed meshes: what ngcontact needs to run under ``mpiexec -n N`` (N >= 2).

Under mpiexec the geometries mesh on rank 0 and distribute the mesh (``distributed_mesh``):
rank 0 keeps no elements, ranks 1 .. N−1 share them (NGSolve's convention), so that
``mpiexec -n 2`` computes on one rank and ``-n 3`` on two. Serial runs never import mpi4py
and take the unchanged serial code paths.

On a distributed mesh

* numpy views of vectors (``vec.FV().NumPy()``) hold the rank's own DOFs; a DOF on the
  interface of two ranks appears on both. A vector is *cumulated* (every copy holds the
  value: GridFunctions, solutions) or *distributed* (the copies sum to the value: assembled
  residuals and load vectors); ``cumulated`` gives a numpy copy of the values;
* a global sum over DOFs counts each DOF once, on the rank that ``owned`` marks;
* ``Integrate(f * dx, mesh)`` and facet arrays on Γ3 are the rank's part (the facets of Γ3
  belong to one rank each): ``sum``, ``maximum``, ``minimum`` combine them over the ranks;
* matrices are NGSolve ``ParallelMatrix``; ``local_matrix`` is the rank's part, whose
  diagonal is distributed.

Every helper takes the mesh (or a space or vector on it) and is the identity on a serial mesh.
"""
import os

import ngsolve as ngs
import numpy as np

from ngcontact import mpi_launch

def world():
    """mpi4py's COMM_WORLD when this process is one of several MPI ranks (started by
    mpiexec), else None (mpi4py is then not imported)."""
    if not mpi_launch.launched():
        return None
    from mpi4py import MPI
    return MPI.COMM_WORLD if MPI.COMM_WORLD.size > 1 else None


def oversubscribed():
    """True if more MPI ranks run than this machine has cores (``os.cpu_count()``): every
    collective operation then waits for a descheduled rank (PETSc's GMRES on more ranks than
    cores: docs/measurements.md, section ngcontact/parallel.py). True on every rank if true on some
    (nodes with fewer cores): the solver it chooses is the same on every rank. Collective:
    every rank calls it."""
    comm = world()
    if comm is None:
        return False
    from mpi4py import MPI
    return bool(comm.allreduce(comm.size > (os.cpu_count() or 1), op=MPI.LOR))


def rank():
    """This process's rank in COMM_WORLD (0 in a serial run)."""
    comm = world()
    return 0 if comm is None else comm.rank


def distributed_mesh(make, refine, comm):
    """An ``ngsolve.Mesh`` distributed over ``comm`` (mpi4py): rank 0 builds the netgen mesh
    by ``make()``, refines it ``refine`` times (``Mesh.Refine`` of a distributed mesh gives a
    broken parallel topology in NGSolve 6.2.2608: wrong global DOF counts, hangs) and
    distributes it; the other ranks receive their parts."""
    from netgen.meshing import Mesh as NetgenMesh
    elements = 0
    if comm.rank == 0:
        ngmesh = make()
        serial = ngs.Mesh(ngmesh)
        for _ in range(refine):
            serial.Refine()
        elements = serial.ne
    elements = comm.bcast(elements, root=0)
    if elements < comm.size - 1:                  # every rank raises, before distributing
        raise ValueError(f"mpiexec -n {comm.size}: the mesh has {elements} elements for {comm.size - 1} "
                         f"computing ranks (rank 0 keeps none); run on at most {elements + 1} ranks or "
                         f"refine the mesh")
    if comm.rank == 0:
        ngmesh = ngmesh.Distribute(comm)
    else:
        ngmesh = NetgenMesh.Receive(comm)
    return ngs.Mesh(ngmesh)


def is_distributed(mesh):
    """True if ``mesh`` is distributed over several MPI ranks."""
    return mesh.comm.size > 1


def comm_of(mesh):
    """The mpi4py communicator of a distributed mesh, None for a serial one."""
    return mesh.comm.mpi4py if is_distributed(mesh) else None


def _reduce(mesh, value, op):
    comm = comm_of(mesh)
    if comm is None:
        return value
    from mpi4py import MPI
    return comm.allreduce(value, op=getattr(MPI, op))


def sum(mesh, value):             # noqa: A001 (the name says what it does)
    """The sum over the ranks of a number or numpy array (``value`` itself when serial)."""
    return _reduce(mesh, value, "SUM")


def maximum(mesh, values, initial=-np.inf):
    """max of a numpy array over all ranks (``initial`` where every rank's part is empty)."""
    return float(_reduce(mesh, float(np.max(values, initial=initial)), "MAX"))


def minimum(mesh, values, initial=np.inf):
    """min of a numpy array over all ranks (``initial`` where every rank's part is empty)."""
    return float(_reduce(mesh, float(np.min(values, initial=initial)), "MIN"))


def any_rank(mesh, flag):
    """True if ``flag`` is true on some rank."""
    return bool(_reduce(mesh, bool(flag), "LOR"))


def size(mesh=None):
    """The number of ranks ``mesh`` is distributed over (1 for a serial mesh); without a mesh,
    the number of MPI ranks of this run (1 without mpiexec)."""
    if mesh is None:
        comm = world()
        return 1 if comm is None else comm.size
    return mesh.comm.size


def every(mesh, value):
    """[value of rank 0, value of rank 1, ...] for any picklable ``value``, on every rank
    ([value] when serial)."""
    comm = comm_of(mesh)
    return [value] if comm is None else comm.allgather(value)


def gather(mesh, values):
    """The numpy arrays of all ranks, concatenated in rank order along the first axis
    (``values`` itself when serial): per-facet arrays of Γ3 as one array on every rank."""
    if comm_of(mesh) is None:
        return values
    return np.concatenate(every(mesh, np.asarray(values)), axis=0)


def offset(mesh, count):
    """(the items on the ranks before this one, the items on all ranks) for ``count`` items
    on this rank: where its items start in an array gathered in rank order (``gather``)."""
    counts = every(mesh, int(count))
    return int(np.sum(counts[:mesh.comm.rank])), int(np.sum(counts))


def barrier(mesh):
    """Wait until every rank of ``mesh`` is here (nothing when serial)."""
    comm = comm_of(mesh)
    if comm is not None:
        comm.Barrier()


def together(mesh, check, *args, errors=(ValueError,)):
    """``check(*args)`` on every rank, its result returned; an exception of the kinds
    ``errors`` (default ValueError) raised on some ranks is raised on every rank, of the lowest
    such rank's type with its message (an OSError's naming that rank), so that no rank goes on
    into a collective operation the others have left, or waits for ever in one that a failed
    rank never reaches. ``check`` itself must not communicate."""
    comm = comm_of(mesh)
    if comm is None:
        return check(*args)
    try:
        result, failure = check(*args), None
    except errors as err:
        message = f"rank {comm.rank}: {err}" if isinstance(err, OSError) else str(err)
        result, failure = None, (type(err), message)
    failed = [f for f in comm.allgather(failure) if f is not None]
    if failed:
        kind, message = failed[0]
        raise kind(message) from None
    return result


def cumulated(vec):
    """A numpy copy of the values of an NGSolve vector, with the copies of an interface DOF
    summed if the vector is distributed (a view of the vector when it is not parallel)."""
    status = vec.GetParallelStatus()
    if status == ngs.la.PARALLEL_STATUS.NOT_PARALLEL:
        return vec.FV().NumPy()
    if status == ngs.la.PARALLEL_STATUS.DISTRIBUTED:
        copy = vec.CreateVector()
        copy.data = vec
        copy.Cumulate()
        return copy.FV().NumPy().copy()
    return vec.FV().NumPy().copy()


def set_cumulated(vec, values):
    """Set the values of a vector (numpy, as ``cumulated`` gives them) and mark it cumulated."""
    vec.FV().NumPy()[:] = values
    if vec.GetParallelStatus() == ngs.la.PARALLEL_STATUS.DISTRIBUTED:
        vec.SetParallelStatus(ngs.la.PARALLEL_STATUS.CUMULATED)


def distributed_values(template, values):
    """numpy ``values`` given as distributed contributions (summed over the ranks sharing a
    DOF), cumulated into a numpy array like ``cumulated``; ``template`` is a vector of the
    space whose parallel DOFs are used."""
    vec = template.CreateVector()
    vec.FV().NumPy()[:] = values
    vec.SetParallelStatus(ngs.la.PARALLEL_STATUS.DISTRIBUTED)
    vec.Cumulate()
    return vec.FV().NumPy().copy()


def owned(space):
    """Boolean numpy array over the DOFs of ``space``: those this rank counts in global sums
    (each DOF on exactly one rank, NGSolve's master DOFs); all True for a serial space."""
    parallel_dofs = space.ParallelDofs()
    if parallel_dofs is None or space.mesh.comm.size == 1:
        return np.ones(space.ndof, dtype=bool)
    return np.array(list(parallel_dofs.MasterDofs()), dtype=bool)


def local_matrix(matrix):
    """The rank's part of a ParallelMatrix, the matrix itself when it is not parallel."""
    return getattr(matrix, "local_mat", matrix)


def refuse_under_mpiexec(what):
    """Raise a ValueError naming ``what`` (a command that runs serially only) when this
    process is one of several MPI ranks: each rank would run the whole serial problem."""
    comm = world()
    if comm is not None:
        raise ValueError(f"{what} runs serially only: under mpiexec with {comm.size} ranks every rank would "
                         "run the whole serial problem; run it without mpiexec")


def serial_only(mesh, feature, why=""):
    """Raise a ValueError naming ``feature`` when ``mesh`` is distributed."""
    if is_distributed(mesh):
        raise ValueError(f"{feature} does not run on a distributed mesh (mpiexec with "
                         f"{mesh.comm.size} ranks){': ' + why if why else ''}")


def point_values(mesh, cf, points):
    """cf at ``points`` (an array of coordinates, points × dim) as a numpy array (points ×
    cf.dim), on every rank: on a distributed mesh each point is evaluated by the ranks whose
    elements hold it and averaged over them (a continuous field agrees there to round-off).
    A point outside the mesh raises a ValueError."""
    points = np.atleast_2d(np.asarray(points, dtype=float))
    values, found = np.zeros((len(points), cf.dim)), np.zeros(len(points))
    for i, point in enumerate(points):
        mapped = mesh(*point)
        if mapped.nr >= 0:
            values[i], found[i] = np.ravel(cf(mapped)), 1.0
    values, found = sum(mesh, values), sum(mesh, found)
    if not found.all():
        raise ValueError(f"points {points[found == 0].tolist()} are outside the mesh")
    return values / found[:, None]
