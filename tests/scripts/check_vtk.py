#!/usr/bin/env python3
"""Loads a biodem snapshots.pvd with VTK's own XML readers and checks the SPEC 11 fields.
Usage: check_vtk.py OUT_DIR EXPECTED_SPHERES. Exit 0 and prints a summary on success."""
import os, sys, xml.etree.ElementTree as ET
import vtk

out, expected = sys.argv[1], int(sys.argv[2])
pvd = ET.parse(os.path.join(out, "snapshots.pvd")).getroot()
files = [d.get("file") for d in pvd.iter("DataSet")]
assert files, "snapshots.pvd lists no data sets"
for f in files:
    r = vtk.vtkXMLUnstructuredGridReader()
    r.SetFileName(os.path.join(out, f))
    r.Update()
    g = r.GetOutput()
    assert g.GetNumberOfPoints() == expected, f"{f}: {g.GetNumberOfPoints()} points, expected {expected}"
    pd = g.GetPointData()
    for name, comps in (("velocity", 3), ("speed", 1), ("radius", 1), ("body_id", 1)):
        a = pd.GetArray(name)
        assert a is not None, f"{f}: no point array {name}"
        assert a.GetNumberOfComponents() == comps, f"{f}: {name} has {a.GetNumberOfComponents()} components"
        assert a.GetNumberOfTuples() == expected
    rad = pd.GetArray("radius").GetRange()
    assert rad[0] > 0, f"{f}: non-positive radius"
print(f"ok: {len(files)} snapshots, {expected} points each")
