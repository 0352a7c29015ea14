"""ParaView files of a run: u and φ through NGSolve's ``VTKOutput`` (checked: it says nothing
when it cannot write its file), and the facets of Γ3 with their fields as VTK PolyData.
``results`` writes them into a streamed run's directory; ``FieldsSeries`` is ``run(vtk=)``."""
import pathlib

import ngsolve as ngs
import numpy as np

from ngcontact import parallel


class FieldsSeries:
    """``run(vtk=STEM)``: NGSolve's VTKOutput of u and φ into ``STEM.vtu``,
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


def fields_writer(source, filename, **options):
    """NGSolve's VTKOutput of u and φ ("displacement", "potential") of ``source`` into
    ``filename`` (a stem; ``options`` such as ``legacy=False`` go to VTKOutput)."""
    return ngs.VTKOutput(source.mesh, coefs=list(source.fields), names=["displacement", "potential"],
                         filename=str(filename), subdivision=source.subdivision, **options)


def gamma3_vtp(facets, contact):
    """The facets of Γ3 (their vertices, facets × dim × dim, in the order of the record's
    arrays) as VTK PolyData (lines in 2D, triangles in 3D), fields as cell data."""
    dim = facets.shape[-1]
    points = np.zeros((facets.shape[0] * dim, 3))
    points[:, :dim] = facets.reshape(-1, dim)
    cells = np.arange(len(points)).reshape(-1, dim)
    offsets = np.arange(1, len(facets) + 1) * dim
    kind = "Lines" if dim == 2 else "Polys"

    def array(name, values, typ="Float64", components=1):
        text = " ".join(repr(float(v)) if typ == "Float64" else str(int(v)) for v in np.ravel(values))
        return (f'<DataArray type="{typ}" Name="{name}" NumberOfComponents="{components}" format="ascii">'
                f"{text}</DataArray>\n")
    fields = dict(beta=contact.beta, pressure=contact.pressure, multiplier=contact.multiplier,
                  charge_flux_density=contact.charge_flux_density, potential=contact.potential,
                  contact_set=contact.contact_set)
    counts = f'NumberOfLines="{len(facets) if dim == 2 else 0}" NumberOfPolys="{len(facets) if dim == 3 else 0}"'
    return ('<?xml version="1.0"?>\n<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian">\n'
            f'<PolyData>\n<Piece NumberOfPoints="{len(points)}" NumberOfVerts="0" {counts} NumberOfStrips="0">\n'
            "<Points>\n" + array("points", points, components=3) + "</Points>\n"
            f"<{kind}>\n" + array("connectivity", cells, "Int64") + array("offsets", offsets, "Int64")
            + f"</{kind}>\n<CellData>\n" + "".join(array(k, v) for k, v in fields.items())
            + "</CellData>\n</Piece>\n</PolyData>\n</VTKFile>\n")
