"""ParaView files of a run (docs/output.md): u and φ through NGSolve's ``VTKOutput`` (checked: it
says nothing when it cannot write its file), and the facets of Γ3 with their fields as a VTK
UnstructuredGrid (``.vtu``: lines in 2D, triangles in 3D). Every file is binary XML VTK that
ParaView, PyVista and meshio read; vectors have 3 components (z = 0 in 2D and on a section,
as DOLFINx and meshio write them), so that Warp By Vector moves the points by u. ``results``
writes them into a streamed run's directory; ``FieldsSeries`` is ``run(vtk=)``."""
import pathlib

import ngsolve as ngs
import numpy as np

from ngcontact import parallel


class FieldsSeries:
    """``run(vtk=STEM)``: NGSolve's VTKOutput of u (3 components) and φ into ``STEM.vtu``,
    ``STEM_step00001.vtu``, ... (distributed: ``STEM_procR.vtu``, ``STEM_procR_step00001.vtu``
    per computing rank R) and ``STEM.pvd``, one file per call ``series(time)``. VTKOutput does
    not report a file it could not write: each rank checks its own, and an OSError on any
    rank is raised on every rank, naming the time, the rank and the file."""

    def __init__(self, source, stem):
        self.mesh, self.stem, self.calls = source.mesh, pathlib.Path(stem), 0
        self.writer = fields_writer(source, stem, legacy=False)

    def __call__(self, time):
        try:
            parallel.together(self.mesh, self._write, time, errors=(OSError,))
        except OSError as err:
            raise type(err)(f"vtk: the fields at t = {time:.6g} s could not be written ({err})") from None
        self.calls += 1

    def _write(self, time):
        checked_vtk(self.writer, time, own_vtu(self.mesh, self.stem, f"_step{self.calls:05d}" if self.calls else ""))


def own_vtu(mesh, stem, suffix=""):
    """The .vtu file this rank's VTKOutput writes for ``stem`` (and ``suffix``, its step):
    ``stem + suffix``, distributed ``stem_procR + suffix`` on computing rank R; None on rank 0
    of a distributed mesh, which holds no cells."""
    stem = pathlib.Path(stem)
    if not parallel.is_distributed(mesh):
        return stem.with_name(f"{stem.name}{suffix}.vtu")
    rank = mesh.comm.rank
    return None if rank == 0 else stem.with_name(f"{stem.name}_proc{rank}{suffix}.vtu")


def checked_vtk(writer, time, written):
    """``writer.Do(time=time)`` (NGSolve's VTKOutput), and an OSError unless it wrote the
    file ``written`` (this rank's; None: rank 0 of a distributed mesh, which writes no cells).
    The file is removed first, so that one of an earlier run cannot pass for it."""
    if written is not None:
        written.unlink(missing_ok=True)
    writer.Do(time=time)
    if written is not None and not written.is_file():
        raise OSError(f"NGSolve's VTKOutput did not write {str(written)!r}")


def three(u):
    """The vector CoefficientFunction ``u`` with 3 components: (u_x, u_y, 0) in 2D (on a
    section (u_r, u_z, 0)), ``u`` itself in 3D."""
    return u if u.dim == 3 else ngs.CF((u[0], u[1], 0))


def fields_writer(source, filename, **options):
    """NGSolve's VTKOutput of u (m, 3 components: "displacement") and φ (V: "potential") of
    ``source`` into ``filename`` (a stem; ``options`` such as ``legacy=False`` go to VTKOutput)."""
    u, phi = source.fields
    return ngs.VTKOutput(source.mesh, coefs=[three(u), phi], names=["displacement", "potential"],
                         filename=str(filename), subdivision=source.subdivision, **options)


def vertex_displacement(mesh, u, facets):
    """u (m) at the vertices of ``facets`` (facets × dim × dim, this rank's facets of Γ3) as
    (facets · dim) × 3, z = 0 in 2D: the displacement the Γ3 file carries for Warp By Vector.
    Each vertex is looked up on the boundary of this rank's mesh (u is continuous there)."""
    points = facets.reshape(-1, facets.shape[-1])
    values = np.zeros((len(points), 3))
    if len(points):
        mapped = mesh(*points.T, VOL_or_BND=ngs.BND)
        lost = mapped["nr"] < 0
        if lost.any():
            raise ValueError(f"Γ3 file: the vertices {points[lost][:3].tolist()} are not on the mesh's boundary")
        values[:, :u.dim] = np.asarray(u(mapped)).reshape(len(points), u.dim)
    return values


VTK_LINE, VTK_TRIANGLE = 3, 5
VTK_TYPES = {"<f8": "Float64", "<i8": "Int64", "u1": "UInt8"}
GAMMA3_FIELDS = ("beta", "pressure", "multiplier", "charge_flux_density", "potential", "contact_set")
"""The ContactRecord's per-facet fields the Γ3 file holds as cell data."""


def gamma3_vtu(facets, displacement, contact):
    """The facets of Γ3 (their vertices, facets × dim × dim, in the order of the record's
    arrays) as a binary VTK UnstructuredGrid: lines in 2D, triangles in 3D, each facet with
    its own dim points; ``displacement`` (the points × 3, m) as point data, the fields
    ``GAMMA3_FIELDS`` of ``contact`` as cell data. Returns the file's bytes."""
    dim = facets.shape[-1]
    points = np.zeros((facets.shape[0] * dim, 3))
    points[:, :dim] = facets.reshape(-1, dim)
    cells = np.arange(len(points)).reshape(-1, dim)
    cell_data = {name: getattr(contact, name) for name in GAMMA3_FIELDS}
    return vtu(points, cells, VTK_LINE if dim == 2 else VTK_TRIANGLE, dict(displacement=displacement), cell_data)


def vtu(points, cells, cell_type, point_data, cell_data):
    """A VTK XML UnstructuredGrid of one cell type (``cells``: cells × vertices, indices
    into ``points``, points × 3) with named point and cell arrays (Float64: a 1D array is a
    scalar, points × 3 or cells × 3 a 3-component vector), binary: raw appended data, each array
    after its UInt64 byte count. Returns the file's bytes."""
    cells = np.asarray(cells, dtype=np.int64)
    arrays, blocks, offset = [], [], 0

    def add(section, name, values, dtype):
        nonlocal offset
        values = np.ascontiguousarray(values, dtype=dtype)
        components = f' NumberOfComponents="{values.shape[1]}"' if values.ndim == 2 else ""
        arrays.append((section, f'<DataArray type="{VTK_TYPES[dtype]}" Name="{name}"{components} '
                                f'format="appended" offset="{offset}"/>'))
        data = values.tobytes()
        blocks.append(np.uint64(len(data)).tobytes() + data)
        offset += 8 + len(data)

    add("Points", "Points", points, "<f8")
    add("Cells", "connectivity", cells.ravel(), "<i8")
    add("Cells", "offsets", np.arange(1, len(cells) + 1) * cells.shape[1], "<i8")
    add("Cells", "types", np.full(len(cells), cell_type), "u1")
    for name, values in point_data.items():
        add("PointData", name, values, "<f8")
    for name, values in cell_data.items():
        add("CellData", name, values, "<f8")
    body = "".join(f"<{section}>\n" + "".join(f"{a}\n" for s, a in arrays if s == section) + f"</{section}>\n"
                   for section in ("Points", "Cells", "PointData", "CellData"))
    head = ('<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" '
            f'header_type="UInt64">\n<UnstructuredGrid>\n<Piece NumberOfPoints="{len(points)}" '
            f'NumberOfCells="{len(cells)}">\n{body}</Piece>\n</UnstructuredGrid>\n<AppendedData encoding="raw">\n_')
    return head.encode() + b"".join(blocks) + b"\n</AppendedData>\n</VTKFile>\n"
