#!/usr/bin/python3
"""Top view of a mill run from its own output (run.h5 and the scene): the gas speed on the
mid-plane as coloured cells, the particles of the last snapshot as discs coloured by size (log
scale), the chamber, the outlet tube and the nozzles' jets. Writes an SVG.

    /usr/bin/python3 bench/mill_picture.py RUN_DIR SCENE.json OUT.svg
Needs python3-h5py and python3-numpy (Debian).
"""
import json
import math
import sys

import h5py
import numpy as np


def ramp(t):
    """A perceptually ordered colour ramp (dark blue → teal → yellow), t in [0, 1]."""
    stops = [(0.0, (0x2c, 0x1e, 0x5c)), (0.35, (0x21, 0x7d, 0x8c)), (0.7, (0x5e, 0xc9, 0x62)),
             (1.0, (0xfd, 0xe7, 0x25))]
    t = min(max(t, 0.0), 1.0)
    for (t0, c0), (t1, c1) in zip(stops, stops[1:]):
        if t <= t1:
            f = (t - t0) / (t1 - t0)
            return "#%02x%02x%02x" % tuple(int(a + f * (b - a)) for a, b in zip(c0, c1))
    return "#fde725"


def main():
    run_dir, scene_path, out_path = sys.argv[1:4]
    scene = json.load(open(scene_path))
    mill = scene["mill"]
    cx, cy = mill.get("center_xy_m", [0, 0])
    radius = mill["radius_m"]
    zmin, zmax = scene["domain"]["min_m"][2], scene["domain"]["max_m"][2]
    with h5py.File(f"{run_dir}/run.h5", "r") as f:
        gas = {k: np.array(f["gas"][k]) for k in f["gas"].keys()}
        last = sorted(f["snapshots"].keys())[-1]
        snap = f["snapshots"][last]
        pos = np.array(snap["position"])
        dia = np.array(snap["diameter"])
        t_s = float(snap.attrs["time_s"])
    size = 640.0
    margin = 40.0
    scale = (size - 2 * margin) / (2 * radius)
    sx = lambda x: margin + (x - (cx - radius)) * scale
    sy = lambda y: size - margin - (y - (cy - radius)) * scale
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{size + 160:.0f}" height="{size:.0f}" '
           f'font-family="sans-serif" font-size="12">', f'<rect width="100%" height="100%" fill="white"/>']
    # Gas speed on the cell layer nearest the mid-plane.
    zs = np.unique(np.round(gas["z_m"], 12))
    mid = zs[np.argmin(abs(zs - 0.5 * (zmin + zmax)))]
    layer = abs(gas["z_m"] - mid) < 1e-12
    speed = np.hypot(gas["velocity_x_m_per_s"], gas["velocity_y_m_per_s"])[layer]
    xs, ys = gas["x_m"][layer], gas["y_m"][layer]
    hx = np.min(np.diff(np.unique(np.round(xs, 12)))) if len(xs) > 1 else 1e-3
    vmax = float(np.percentile(speed, 99)) if len(speed) else 1.0
    for x, y, s in zip(xs, ys, speed):
        out.append(f'<rect x="{sx(x - hx / 2):.1f}" y="{sy(y + hx / 2):.1f}" width="{hx * scale + 0.6:.1f}" '
                   f'height="{hx * scale + 0.6:.1f}" fill="{ramp(s / vmax)}"/>')
    # Chamber, outlet tube, nozzles.
    out.append(f'<circle cx="{sx(cx):.1f}" cy="{sy(cy):.1f}" r="{radius * scale:.1f}" fill="none" stroke="black" stroke-width="2"/>')
    ro = mill["outlet"]["radius_m"]
    out.append(f'<circle cx="{sx(cx):.1f}" cy="{sy(cy):.1f}" r="{ro * scale:.1f}" fill="none" stroke="black" stroke-width="1.5" stroke-dasharray="4 3"/>')
    for n in mill.get("nozzles", []):
        count = n.get("count", 1)
        for k in range(count):
            phi = math.radians(n.get("azimuth_deg", 0) + 360.0 * k / count)
            alpha = math.radians(n.get("angle_to_tangent_deg", 40))
            ex, ey = cx + radius * math.cos(phi), cy + radius * math.sin(phi)
            dx = -math.sin(phi) * math.cos(alpha) - math.cos(phi) * math.sin(alpha)
            dy = math.cos(phi) * math.cos(alpha) - math.sin(phi) * math.sin(alpha)
            L = 0.2 * radius
            out.append(f'<line x1="{sx(ex):.1f}" y1="{sy(ey):.1f}" x2="{sx(ex + L * dx):.1f}" y2="{sy(ey + L * dy):.1f}" '
                       f'stroke="#d62728" stroke-width="3"/>')
    # Particles, coloured by log size.
    if len(dia):
        lo, hi = math.log(max(dia.min(), 1e-9)), math.log(dia.max())
        order = np.argsort(-dia)
        for i in order:
            t = (math.log(dia[i]) - lo) / (hi - lo) if hi > lo else 1.0
            r = max(0.8, 0.5 * dia[i] * scale)
            hue = ramp(1.0 - t)
            out.append(f'<circle cx="{sx(pos[i][0]):.1f}" cy="{sy(pos[i][1]):.1f}" r="{r:.1f}" fill="{hue}" stroke="black" stroke-width="0.3"/>')
    # Legends.
    lx = size + 10
    out.append(f'<text x="{lx}" y="40">gas speed, mid-plane</text>')
    for k in range(6):
        out.append(f'<rect x="{lx}" y="{50 + 16 * k}" width="14" height="14" fill="{ramp(k / 5)}"/>'
                   f'<text x="{lx + 20}" y="{61 + 16 * k}">{vmax * k / 5:.0f} m/s</text>')
    out.append(f'<text x="{lx}" y="170">particles by size</text>')
    if len(dia):
        for k in range(6):
            d = math.exp(lo + (hi - lo) * (1 - k / 5))
            out.append(f'<circle cx="{lx + 7}" cy="{187 + 16 * k}" r="6" fill="{ramp(k / 5)}" stroke="black" stroke-width="0.3"/>'
                       f'<text x="{lx + 20}" y="{191 + 16 * k}">{d * 1e6:.0f} µm</text>')
    out.append(f'<text x="{lx}" y="300">t = {t_s * 1e3:.2f} ms</text>')
    out.append(f'<text x="{lx}" y="316">{len(dia)} particles</text>')
    out.append(f'<text x="{lx}" y="340" fill="#d62728">red: nozzle jets</text>')
    out.append(f'<text x="{lx}" y="356">dashed: outlet tube</text>')
    out.append("</svg>")
    open(out_path, "w").write("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
