"""The blocks of a step Jacobian J in PETSc's numbering (``petsc_iterative``): the index sets of
J's rows of a field or of a set of DOFs, u's rows node by node for GAMG, and the rigid-body
motions of u (GAMG's near null space), on this process's part of the mesh."""
import ngsolve as ngs
import numpy as np


def rigid_motion_values(body, X):
    """The rigid-body motions of u (2D: the translations and the rotation about z; 3D: the
    translations and the rotations about x, y, z) as arrays over the DOFs of the product space
    ``X`` (u first; φ 0), on this process's part of the mesh.

    With NGSolve's hierarchical H1 basis a linear function is its vertex values (DOF v of each
    component is vertex v, the higher-order DOFs are 0; on a straight-sided mesh exactly what
    ``GridFunction.Set`` gives, to round-off): read from the vertex coordinates instead of 6
    ``Set`` calls, slow on large meshes (docs/measurements.md, section
    ngcontact/solve/linalg/petsc_blocks.py)."""
    dim, V = body.dim, body.V
    if body.mesh.ne == 0:                                 # rank 0 of a distributed mesh: no elements
        for _ in range(3 if dim == 2 else 6):
            yield np.zeros(X.ndof)
        return
    scalar = V.ndof // dim                                # VectorH1: one H1 space per component
    points = np.array(body.mesh.ngmesh.Coordinates())[:, :dim]
    if V.ndof != dim * scalar or len(points) != body.mesh.nv or scalar < body.mesh.nv:
        raise ValueError(f"rigid motions need u in a VectorH1 space ({V.ndof} DOFs, {body.mesh.nv} vertices)")
    x, y = points[:, 0], points[:, 1]
    one, zero = np.ones_like(x), np.zeros_like(x)
    if dim == 2:
        motions = [(one, zero), (zero, one), (-y, x)]
    else:
        z = points[:, 2]
        motions = [(one, zero, zero), (zero, one, zero), (zero, zero, one), (-y, x, zero), (zero, -z, y),
                   (z, zero, -x)]
    nv = len(points)
    for motion in motions:
        values = np.zeros(X.ndof)
        for component, part in enumerate(motion):
            values[component * scalar:component * scalar + nv] = part
        yield values


def node_by_node(PETSc, mapping, template, rows, ncomp, n_u):
    """u's rows of J (the index set ``rows``) reordered node by node, the ``ncomp`` components
    of each scalar DOF together, as an index set of block size ncomp: GAMG then aggregates
    nodes (its graph of the ncomp × ncomp blocks) instead of single components, a smaller graph
    for the same CG iterations (docs/measurements.md, section
    ngcontact/solve/linalg/petsc_blocks.py). VectorH1 numbers its
    DOFs component by component (the first n_u/ncomp are x); each DOF is tagged with
    (its owner's rank, its scalar DOF, its component), which the owner's copy carries into J's
    numbering; distributed, PETSc's rows of one node may be on different ranks, so every node's
    rows are sent to its NGSolve master, which obtains them in the block (the index set holds
    the rows this rank obtains, owned here or not). ``rows`` is returned unchanged (block size
    1) where some scalar DOF has fewer than ncomp free components (a support that holds one
    component of u)."""
    nscalar = n_u // ncomp
    comm = rows.getComm().tompi4py() if rows.getComm().getSize() > 1 else None
    rank = 0 if comm is None else comm.rank
    dof = np.arange(n_u, dtype=np.int64)
    tag = np.zeros(len(template.FV().NumPy()))
    tag[:n_u] = (((rank << 32) + dof % nscalar) * 4 + dof // nscalar).astype(np.float64)   # exact below 2^53
    tagged = petsc_vector(mapping, template, tag)
    start, _ = tagged.getOwnershipRange()
    indices = rows.getIndices()
    values = np.rint(tagged.getArray(readonly=True)[indices - start]).astype(np.int64)
    if comm is not None:         # PETSc's rows of a node may lie on several ranks: each node's go to
        owner = values // 4 >> 32    # its NGSolve master (its tag's rank), which takes them in the block
        sent = comm.alltoall([np.stack([indices[owner == r], values[owner == r]]) for r in range(comm.size)])
        indices, values = (np.concatenate([part[i] for part in sent]) for i in (0, 1))
    node, component = values // 4, values % 4
    order = np.lexsort((component, node))
    grouped = len(order) % ncomp == 0
    if grouped:
        node, component = node[order].reshape(-1, ncomp), component[order].reshape(-1, ncomp)
        grouped = bool(np.all(node == node[:, :1]) and np.all(component == np.arange(ncomp)))
    if comm is not None:
        from mpi4py import MPI
        grouped = comm.allreduce(grouped, op=MPI.LAND)
    if not grouped:
        return rows
    ordered = PETSc.IS().createGeneral(indices[order].astype(PETSc.IntType), comm=rows.getComm())
    ordered.setBlockSize(ncomp)
    return ordered


def index_set(PETSc, mapping, template, indicator, value):
    """The PETSc index set of the rows of J (free DOFs, ``mapping``'s layout) whose
    ``indicator`` (numpy over the DOFs of ``template``'s space) equals ``value``."""
    marked = petsc_vector(mapping, template, indicator == value)
    start, _ = marked.getOwnershipRange()
    rows = start + np.flatnonzero(marked.getArray() > 0.5)
    return PETSc.IS().createGeneral(rows.astype(PETSc.IntType), comm=marked.getComm())


def petsc_vector(mapping, template, values):
    """``values`` (numpy over the DOFs of ``template``'s space on this process, every copy of
    an interface DOF holding the value) as a PETSc vector in J's numbering (``mapping``,
    ngsPETSc's: a row takes the value of its DOF's NGSolve master)."""
    vec = template.CreateVector()
    vec.FV().NumPy()[:] = values
    if vec.GetParallelStatus() != ngs.la.PARALLEL_STATUS.NOT_PARALLEL:
        vec.SetParallelStatus(ngs.la.PARALLEL_STATUS.CUMULATED)
    return mapping.petscVec(vec)
