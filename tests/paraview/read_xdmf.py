"""Opens a run's XDMF with ParaView's default reader, as a user pressing Apply would, and prints
what it shows as JSON: the reader, the time steps, and at each time the points, cells and
point arrays. Run with pvpython (under xvfb-run on a machine without a display).

usage: pvpython read_xdmf.py RUN.xdmf
"""
import json
import sys

from paraview import servermanager
from paraview.simple import OpenDataFile

reader = OpenDataFile(sys.argv[1])
times = list(reader.TimestepValues) if reader.TimestepValues else [0.0]
steps = []
for t in times:
    # The proxy's own UpdatePipeline: paraview.simple's drops a time of 0.0 (it tests `if time`).
    reader.UpdatePipeline(t)
    data = servermanager.Fetch(reader)
    if data.IsA("vtkMultiBlockDataSet"):
        data = data.GetBlock(0)
    point_data = data.GetPointData()
    steps.append({
        "time": t,
        "points": data.GetNumberOfPoints(),
        "cells": data.GetNumberOfCells(),
        "arrays": sorted(point_data.GetArrayName(i) for i in range(point_data.GetNumberOfArrays())),
    })
print(json.dumps({"reader": reader.GetXMLName(), "steps": steps}))
