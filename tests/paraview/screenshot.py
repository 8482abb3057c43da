"""Renders a run's particles as ParaView shows them with its default reader (the last time
step, points as spheres scaled by nothing, coloured by speed) and saves a PNG. For the pictures
in docs/; run with pvpython under xvfb-run.

usage: pvpython screenshot.py RUN.xdmf OUT.png
"""
import sys

from paraview.simple import (ColorBy, GetActiveViewOrCreate, OpenDataFile, ResetCamera,
                             SaveScreenshot, Show)

reader = OpenDataFile(sys.argv[1])
reader.UpdatePipeline(reader.TimestepValues[-1])
view = GetActiveViewOrCreate("RenderView")
view.ViewTime = reader.TimestepValues[-1]
view.ViewSize = [900, 700]
view.CameraPosition = [0.0, 0.0, 1.0]
view.CameraViewUp = [0.0, 1.0, 0.0]
display = Show(reader, view)
display.SetRepresentationType("Points")
display.PointSize = 2
ColorBy(display, ("POINTS", "speed"))
display.SetScalarBarVisibility(view, True)
ResetCamera(view)
SaveScreenshot(sys.argv[2], view, ImageResolution=[900, 700])
