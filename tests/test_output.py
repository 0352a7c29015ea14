"""ParaView output (docs/output.md): every file ``run(out=DIR)`` writes is read by meshio, the
VTK files are binary, vectors have 3 components, and Γ3's file warps onto the deformed body:
its points moved by its displacement land where the body's file moves the same points of its
boundary. ``run(vtk=)`` is a file stem; a directory is refused with the fix."""
import re
from xml.etree import ElementTree

import meshio
import ngsolve as ngs
import numpy as np
import pytest

import ngcontact as ngc
from ngcontact.obstacles import Plane
from ngcontact.output.paraview import GAMMA3_FIELDS
from ngcontact.scenes import hertz, reference

DT = 0.05                      # s, the reference scene's steps (contact from the first one)
NOT_MESHES = {".json", ".npz", ".pvd"}       # run.json, the step archives, the series


def read_every_file(directory):
    """{path relative to ``directory``: meshio.Mesh} of every file in it that is not of
    ``NOT_MESHES`` (each must be a .vtu that meshio reads)."""
    meshes = {}
    for path in sorted(p for p in directory.rglob("*") if p.is_file()):
        if path.suffix not in NOT_MESHES:
            assert path.suffix == ".vtu", path
            meshes[path.relative_to(directory).as_posix()] = meshio.read(path)
    return meshes


def formats(path):
    """The ``format`` attributes of the DataArrays of a VTK XML file (its header, before
    the appended binary data)."""
    head = path.read_bytes().split(b"<AppendedData")[0].decode()
    return set(re.findall(r'<DataArray[^>]* format="(\w+)"', head))


def series(path):
    """[(time, file)] of a .pvd collection."""
    return [(float(e.get("timestep")), e.get("file"))
            for e in ElementTree.parse(path).getroot().findall("Collection/DataSet")]


def check_warp(body, gamma3):
    """Every point of Γ3's file is a point of the body's file (the same place to 1e-12 of the
    body's size), and warped by its displacement it lands where the body's file warps every
    copy of that point (VTKOutput writes a point per element), to 1e-12 of the largest
    displacement. Returns the largest displacement on Γ3 (m)."""
    points, u = body.points, body.point_data["displacement"]
    size, largest = np.abs(points).max(), np.abs(u).max()
    distance = np.linalg.norm(gamma3.points[:, None] - points[None], axis=-1)
    same = distance <= 1e-12 * size
    assert same.any(axis=1).all(), gamma3.points[~same.any(axis=1)]
    warped = gamma3.points + gamma3.point_data["displacement"]
    for i, copies in enumerate(same):
        assert np.abs(points[copies] + u[copies] - warped[i]).max() <= 1e-12 * largest
    return np.abs(gamma3.point_data["displacement"]).max()


def check_run(directory, sim, cell):
    """The files of ``sim.run(..., out=directory)``: read by meshio, binary, the series
    listing every step; per step the body's u (3 components) and φ, Γ3's facets as ``cell``
    cells with the record's fields and warping with the body."""
    meshes = read_every_file(directory)
    steps = len(sim.history)
    assert sorted(meshes) == [f"vtk/{name}_{n:06d}.vtu" for name in ("fields", "gamma3") for n in range(steps)]
    for name in meshes:
        assert formats(directory / name) == {"appended"}, name                  # no ASCII DataArray
        assert b'encoding="raw"' in (directory / name).read_bytes()
    for name in ("fields", "gamma3"):
        assert series(directory / f"{name}.pvd") == [(r.time, f"vtk/{name}_{r.step:06d}.vtu") for r in sim.history]
    dim, side = sim.body.dim, sim.gamma3.side
    moved = 0.0
    for record in sim.history:
        body, gamma3 = (meshes[f"vtk/{name}_{record.step:06d}.vtu"] for name in ("fields", "gamma3"))
        assert body.point_data["displacement"].shape == (len(body.points), 3)
        assert body.point_data["potential"].shape in ((len(body.points),), (len(body.points), 1))
        if dim == 2:
            assert not body.point_data["displacement"][:, 2].any()               # z = 0
        assert list(gamma3.cells_dict) == [cell] and len(gamma3.cells_dict[cell]) == len(side.measure)
        assert gamma3.point_data["displacement"].shape == (len(gamma3.points), 3)
        assert sorted(gamma3.cell_data) == sorted(GAMMA3_FIELDS)
        for field in GAMMA3_FIELDS:
            assert np.array_equal(gamma3.cell_data[field][0], getattr(record.contact, field)), field
        moved = max(moved, check_warp(body, gamma3))
    return moved


@pytest.mark.parametrize("order", [1, 2])
def test_a_2d_run_writes_binary_files_that_meshio_reads_and_gamma3_warps_with_the_body(tmp_path, order):
    """The reference plate, 2 steps: 3 + 3 .vtu files; Γ3 moves by about 20 µm (the check is
    not one of zeros), and the body's file holds the simulation's own u (P2: VTKOutput
    subdivides each element once, Γ3's vertices are among its points)."""
    sim = reference.simulation(order, 0.02)
    sim.run(DT, 2 * DT, out=tmp_path)
    assert check_run(tmp_path, sim, "line") > 1e-6
    body = meshio.read(tmp_path / "vtk" / "fields_000002.vtu")
    points = body.points[:, :2]
    expected = sim.u(sim.body.mesh(points[:, 0], points[:, 1]))
    u = body.point_data["displacement"][:, :2]
    assert np.abs(u - expected).max() <= 1e-12 * np.abs(expected).max()


def test_a_3d_run_writes_triangles_of_gamma3_that_warp_with_the_block(tmp_path):
    sim = reference.simulation(1, 0.02, dim=3)
    sim.run(DT, DT, out=tmp_path)
    assert check_run(tmp_path, sim, "triangle") > 1e-6


def test_a_section_writes_its_meridian_that_warps_like_a_plane_body(tmp_path):
    """A body of revolution (``Body(axisymmetric=True)``): the meridian (r, z) with u = (u_r,
    u_z, 0), Γ3 warping with it (docs/output.md revolves both in ParaView)."""
    t = ngs.Parameter(0.0)
    mesh = hertz.mesh(2, h_contact=0.1, axisymmetric=True)
    body = ngc.Body(mesh, ngc.Material.isotropic(1.0, 0.3, permittivity=1.0), supports={"top": "all"},
                    contact_side="contact", axisymmetric=True)
    sim = ngc.Simulation(body, ngc.Loads(displacement={"top": (0, -0.01 * t)}), time=t,
                         contact=ngc.Contact(obstacle=Plane((0, 0), (0, 1))))
    sim.run(1.0, 2.0, out=tmp_path)
    assert check_run(tmp_path, sim, "line") > 1e-3


def test_vtk_is_a_stem_of_3_component_fields_and_a_directory_is_refused_with_the_fix(tmp_path):
    sim = reference.simulation(1, 0.02)
    sim.run(DT, 2 * DT, vtk=tmp_path / "plate")
    names = [file for _, file in series(tmp_path / "plate.pvd")]
    assert names == ["plate.vtu", "plate_step00001.vtu", "plate_step00002.vtu"]
    for name in names:
        assert formats(tmp_path / name) == {"appended"}
        assert meshio.read(tmp_path / name).point_data["displacement"].shape[1] == 3
    for directory in (str(tmp_path), f"{tmp_path}/new/"):
        with pytest.raises(ValueError, match=rf"^vtk: {re.escape(repr(directory))} names a directory; vtk is a file "
                                             rf"name stem .* pass out={re.escape(repr(directory))}"):
            sim.run(DT, 3 * DT, vtk=directory)
    assert len(sim.history) == 3 and not (tmp_path / "new").exists()
