"""Renders a run as ParaView shows it with its default reader at the last time step: the
particles as points coloured by speed, and, when given, the gas field as a slice through the
middle of the domain coloured by gas speed and the geometry as a faint wireframe. Saves a PNG.
For the pictures in docs/; run with pvpython under xvfb-run.

usage: pvpython screenshot.py RUN.xdmf OUT.png [GAS.xdmf] [GEOMETRY.xdmf]
"""
import sys

from paraview.simple import (ColorBy, GetActiveViewOrCreate, OpenDataFile, ResetCamera,
                             SaveScreenshot, Show, Slice, Threshold)

reader = OpenDataFile(sys.argv[1])
last = reader.TimestepValues[-1]
reader.UpdatePipeline(last)
view = GetActiveViewOrCreate("RenderView")
view.ViewTime = last
view.ViewSize = [900, 700]
view.CameraPosition = [0.0, 0.0, 1.0]
view.CameraViewUp = [0.0, 1.0, 0.0]
if len(sys.argv) > 3:
    gas = OpenDataFile(sys.argv[3])
    gas.UpdatePipeline(last)
    bounds = gas.GetDataInformation().GetBounds()
    fluid = Threshold(Input=gas, Scalars=["CELLS", "fluid"], LowerThreshold=0.5,
                      UpperThreshold=1.5)
    cut = Slice(Input=fluid)
    cut.SliceType.Origin = [(bounds[0] + bounds[1]) / 2, (bounds[2] + bounds[3]) / 2,
                            bounds[4] + 0.3 * (bounds[5] - bounds[4])]
    cut.SliceType.Normal = [0.0, 0.0, 1.0]
    cut_display = Show(cut, view)
    ColorBy(cut_display, ("CELLS", "velocity", "Magnitude"))
    cut_display.Opacity = 0.6
if len(sys.argv) > 4:
    walls = OpenDataFile(sys.argv[4])
    walls_display = Show(walls, view)
    walls_display.SetRepresentationType("Feature Edges")
    ColorBy(walls_display, None)
display = Show(reader, view)
display.SetRepresentationType("Points")
display.PointSize = 2
ColorBy(display, ("POINTS", "speed"))
display.SetScalarBarVisibility(view, True)
ResetCamera(view)
SaveScreenshot(sys.argv[2], view, ImageResolution=[900, 700])
