"""Opens a run's XDMF with ParaView's default reader, as a user pressing Apply would, and prints
what it shows as JSON: the reader, the time steps, and at each time, for each block (particles,
gas, geometry), its points, cells, point arrays and cell arrays. The frames are visited forward
("steps") and then backward, last to first ("backward"), as a user stepping back or looping the
animation does: the reader must open every frame again. Run with pvpython (under xvfb-run on a
machine without a display).

usage: pvpython read_xdmf.py RUN.xdmf
"""
import json
import sys

from paraview import servermanager
from paraview.simple import OpenDataFile
from vtkmodules.vtkCommonDataModel import vtkCompositeDataSet


def arrays(field_data):
    return sorted(field_data.GetArrayName(i) for i in range(field_data.GetNumberOfArrays()))


def blocks(data, name, out):
    """Every leaf data set under `data`, by its block name."""
    if data is None:
        return
    if data.IsA("vtkMultiBlockDataSet"):
        for i in range(data.GetNumberOfBlocks()):
            meta = data.GetMetaData(i) if data.HasMetaData(i) else None
            child = meta.Get(vtkCompositeDataSet.NAME()) if meta else None
            blocks(data.GetBlock(i), child or name, out)
        return
    if data.IsA("vtkMultiPieceDataSet"):  # one piece per block on a single process
        for i in range(data.GetNumberOfPieces()):
            blocks(data.GetPiece(i), name, out)
        return
    out[name] = {
        "points": data.GetNumberOfPoints(),
        "cells": data.GetNumberOfCells(),
        "arrays": arrays(data.GetPointData()),
        "cell_arrays": arrays(data.GetCellData()),
        "bounds": list(data.GetBounds()),
    }


reader = OpenDataFile(sys.argv[1])
times = list(reader.TimestepValues) if reader.TimestepValues else [0.0]


def visit(t):
    # The proxy's own UpdatePipeline: paraview.simple's drops a time of 0.0 (it tests `if time`).
    reader.UpdatePipeline(t)
    found = {}
    blocks(servermanager.Fetch(reader), "data", found)
    return {"time": t, "blocks": found}


steps = [visit(t) for t in times]
backward = [visit(t) for t in reversed(times)]
print(json.dumps({"reader": reader.GetXMLName(), "steps": steps, "backward": backward}))
