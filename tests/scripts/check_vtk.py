#!/usr/bin/env python3
"""Loads a biodem run's snapshots.pvd and bodies.pvd with VTK's own XML readers and checks the
SPEC 11 fields: snapshots/ holds one file per snapshot, one point per sphere (velocity, speed,
radius, body_id); bodies/ one per snapshot, one point per body (velocity, angular_velocity,
speed, mass, body_id, shape, orientation).
Usage: check_vtk.py OUT_DIR EXPECTED_SPHERES [EXPECTED_BODIES]. Exit 0 and prints a summary on
success (EXPECTED_BODIES defaults to EXPECTED_SPHERES: bodies of one sphere)."""
import os, sys, xml.etree.ElementTree as ET
import vtk

out, expected = sys.argv[1], int(sys.argv[2])
expected_bodies = int(sys.argv[3]) if len(sys.argv) > 3 else expected


def check(pvd_name, folder, points, fields, positive):
    pvd = ET.parse(os.path.join(out, pvd_name)).getroot()
    files = [d.get("file") for d in pvd.iter("DataSet")]
    assert files, f"{pvd_name} lists no data sets"
    on_disk = sorted(os.listdir(os.path.join(out, folder)))
    listed = sorted(os.path.basename(f) for f in files)
    assert all(os.path.dirname(f) == folder for f in files), f"{pvd_name}: files outside {folder}/: {files}"
    assert on_disk == listed, f"{folder}/ holds {on_disk}, {pvd_name} lists {listed}"
    for f in files:
        r = vtk.vtkXMLUnstructuredGridReader()
        r.SetFileName(os.path.join(out, f))
        r.Update()
        g = r.GetOutput()
        assert g.GetNumberOfPoints() == points, f"{f}: {g.GetNumberOfPoints()} points, expected {points}"
        pd = g.GetPointData()
        for name, comps in fields:
            a = pd.GetArray(name)
            assert a is not None, f"{f}: no point array {name}"
            assert a.GetNumberOfComponents() == comps, f"{f}: {name} has {a.GetNumberOfComponents()} components"
            assert a.GetNumberOfTuples() == points
        lo = pd.GetArray(positive).GetRange()[0]
        assert lo > 0, f"{f}: non-positive {positive} ({lo})"
    return files


files = check("snapshots.pvd", "snapshots", expected, (("velocity", 3), ("speed", 1), ("radius", 1), ("body_id", 1)),
              "radius")
bfiles = check("bodies.pvd", "bodies", expected_bodies,
               (("velocity", 3), ("angular_velocity", 3), ("speed", 1), ("mass", 1), ("body_id", 1), ("shape", 1),
                ("orientation", 4)), "mass")
assert len(bfiles) == len(files), f"{len(files)} sphere snapshots, {len(bfiles)} body snapshots"
print(f"ok: {len(files)} snapshots, {expected} sphere points and {expected_bodies} body points each")
