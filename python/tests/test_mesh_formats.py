"""Every mesh output format read back by other readers: meshio (Debian python3-meshio) for .ply,
.obj, .vtk and .vtu, VTK's own XML reader (python3-vtk9, optional) for .vtp and .vtu. Points,
triangles, normals, levels and attributes must equal what trilevel.reconstruct returned: bit
for bit for the binary float formats, to the shortest round-tripping text for OBJ.

meshio has no reader for .vtp; our .vtk is an UNSTRUCTURED_GRID of triangles with VECTORS
Normals because meshio's legacy reader takes neither POLYDATA nor a NORMALS section
(docs/mesh-formats.md).

Run by CTest (`ctest -R mesh_formats`), which sets PYTHONPATH and TRILEVEL_CLI like the module's
tests; each reader that is not installed is skipped with a message.
"""
import os
import subprocess
import tempfile
import unittest

import numpy as np

import trilevel

R = 0.025

try:
    import meshio
except ImportError:
    meshio = None
try:
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader, vtkXMLUnstructuredGridReader
except ImportError:
    vtk_to_numpy = None


def bits(a):
    a = np.ascontiguousarray(a)
    return a.view(np.uint8 if a.dtype.itemsize == 1 else np.uint32)


class MeshFormatsTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        p = trilevel.generate_scene("falling-drop", R, frame=3)
        cls.velocity = (np.sin(p * 7.0) * 1.5).astype(np.float32)
        cls.density = (1000.0 + p[:, 1] * 3.0).astype(np.float32)
        (cls.v, cls.t, _, cls.levels, _, cls.normals, cls.attrs) = trilevel.reconstruct(
            p, R, normals="gradient", attributes={"density": cls.density, "velocity": cls.velocity}, return_levels=True)
        cls.positions = p

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def write(self, ext):
        path = os.path.join(self.tmp.name, "m." + ext)
        trilevel.write_mesh(path, self.v, self.t, vertex_level=self.levels, normals=self.normals, attributes=self.attrs)
        return path

    def assert_bits(self, a, b, what):
        a, b = np.asarray(a), np.asarray(b)
        self.assertEqual(a.shape, b.shape, what)
        self.assertEqual(a.dtype.itemsize, b.dtype.itemsize, what)
        self.assertTrue(np.array_equal(bits(a), bits(b)), f"{what} differs bit for bit")

    def triangles_of(self, mesh):
        self.assertEqual([c.type for c in mesh.cells], ["triangle"])
        return mesh.cells[0].data

    def check_meshio_full(self, mesh, velocity, normals):
        self.assert_bits(mesh.points, self.v, "points")
        self.assertTrue(np.array_equal(self.triangles_of(mesh), self.t), "triangles differ")
        self.assert_bits(normals, self.normals, "normals")
        self.assertTrue(np.array_equal(mesh.point_data["level"].astype(np.uint8), self.levels), "levels differ")
        self.assert_bits(mesh.point_data["density"], self.attrs["density"], "density")
        self.assert_bits(velocity, self.attrs["velocity"], "velocity")

    @unittest.skipIf(meshio is None, "SKIPPED: meshio is not installed (Debian python3-meshio)")
    def test_meshio_reads_ply(self):
        m = meshio.read(self.write("ply"))
        pd = m.point_data
        self.check_meshio_full(m, np.stack([pd["velocity_x"], pd["velocity_y"], pd["velocity_z"]], axis=1),
                               np.stack([pd["nx"], pd["ny"], pd["nz"]], axis=1))

    @unittest.skipIf(meshio is None, "SKIPPED: meshio is not installed (Debian python3-meshio)")
    def test_meshio_reads_vtu(self):
        m = meshio.read(self.write("vtu"))
        self.check_meshio_full(m, m.point_data["velocity"], m.point_data["Normals"])
        self.assertEqual(m.point_data["level"].dtype, np.uint8)

    @unittest.skipIf(meshio is None, "SKIPPED: meshio is not installed (Debian python3-meshio)")
    def test_meshio_reads_obj_within_text_precision(self):
        # OBJ holds positions and normals as the shortest text that reads back as the same
        # float32: meshio parses it as float64, whose rounding to float32 is exact. No levels or
        # attributes: OBJ has no place for them.
        m = meshio.read(self.write("obj"))
        self.assert_bits(m.points.astype(np.float32), self.v, "points")
        self.assertTrue(np.array_equal(self.triangles_of(m), self.t), "triangles differ")
        self.assert_bits(m.point_data["obj:vn"].astype(np.float32), self.normals, "normals")

    @unittest.skipIf(meshio is None, "SKIPPED: meshio is not installed (Debian python3-meshio)")
    def test_meshio_reads_legacy_vtk(self):
        m = meshio.read(self.write("vtk"))
        # legacy binary VTK is big-endian, and meshio gives scalars as (n, 1): compare the values
        # in native byte order, scalars as (n,)
        def native(a):
            a = np.asarray(a)
            a = a.astype(a.dtype.newbyteorder("="))
            return a[:, 0] if a.ndim == 2 and a.shape[1] == 1 else a
        m.points = native(m.points)
        m.point_data = {k: native(v) for k, v in m.point_data.items()}
        self.check_meshio_full(m, m.point_data["velocity"], m.point_data["Normals"])

    @unittest.skipIf(vtk_to_numpy is None, "SKIPPED: VTK's Python module is not installed (Debian python3-vtk9)")
    def test_vtk_reads_vtp_and_vtu(self):
        for ext, reader in (("vtp", vtkXMLPolyDataReader), ("vtu", vtkXMLUnstructuredGridReader)):
            with self.subTest(ext):
                r = reader()
                r.SetFileName(self.write(ext))
                r.Update()
                data = r.GetOutput()
                self.assert_bits(vtk_to_numpy(data.GetPoints().GetData()), self.v, "points")
                cells = data.GetPolys() if ext == "vtp" else data.GetCells()
                self.assertTrue(np.array_equal(vtk_to_numpy(cells.GetConnectivityArray()), self.t.ravel()))
                self.assertTrue(np.array_equal(vtk_to_numpy(cells.GetOffsetsArray()), np.arange(0, 3 * len(self.t) + 1, 3)))
                if ext == "vtu":
                    self.assertTrue((vtk_to_numpy(data.GetCellTypesArray()) == 5).all())
                pd = data.GetPointData()
                self.assert_bits(vtk_to_numpy(pd.GetNormals()), self.normals, "normals (the active normals)")
                self.assert_bits(vtk_to_numpy(pd.GetScalars()), self.levels, "levels (the active scalars)")
                self.assertEqual(pd.GetScalars().GetName(), "level")
                self.assert_bits(vtk_to_numpy(pd.GetArray("density")), self.attrs["density"], "density")
                self.assert_bits(vtk_to_numpy(pd.GetArray("velocity")), self.attrs["velocity"], "velocity")

    @unittest.skipIf(meshio is None, "SKIPPED: meshio is not installed (Debian python3-meshio)")
    def test_cli_writes_vtu_and_vtp(self):
        cli = os.environ.get("TRILEVEL_CLI", "")
        if not cli or not os.path.isfile(cli):
            self.skipTest("SKIPPED: TRILEVEL_CLI does not name the trilevel binary")
        particles = os.path.join(self.tmp.name, "p.xyz")
        trilevel.write_particles(particles, self.positions)
        v, t, _, n = trilevel.reconstruct(self.positions, R, normals="gradient")
        for ext in ("vtu", "vtp"):
            out = os.path.join(self.tmp.name, "cli." + ext)
            subprocess.run([cli, "reconstruct", particles, "-o", out, "--radius", str(R), "--normals", "-q"], check=True)
            with open(out, "rb") as f:
                self.assertIn(b'type="PolyData"' if ext == "vtp" else b'type="UnstructuredGrid"', f.read(200))
            if ext == "vtu":
                m = meshio.read(out)
                self.assert_bits(m.points, v, "CLI points")
                self.assertTrue(np.array_equal(self.triangles_of(m), t))
                self.assert_bits(m.point_data["Normals"], n, "CLI normals")


if __name__ == "__main__":
    unittest.main()
