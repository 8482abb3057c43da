#!/usr/bin/python3
"""Whether the ledger dust's exit rates move with what the mill holds (issue 31, item 2).

A hold-up fill projects the dust's steady hold-up from its rates per kilogram over a window
(engine/process/steady_projection.h) and so assumes they stay as they were while the hold-up
moves. With the dust's weight on the gas (dust.gas_coupling "two_way") a heavier ledger may slow
the vortex, and the force-balance cut x_c = sqrt(18 mu |u_r| r / (rho_p u_t^2)) grows as u_t
falls: more of the classes at the cut would leave per kilogram. This script sets the two side by
side, interval by interval, from the run's own records:

- the vortex: the gas's mean tangential and radial speed over the fluid cells whose centres lie
  in a ring of one cell's width about each radius and below the outlet tube's mouth (run.h5's gas
  snapshots), and the cut at the outlet's radius. These are cell values, not the interpolated
  samples of result.json's mill.vortex_profile (process/classification.h: interpolated to the
  exact radius at 16 heights from the floor up), and they read higher speeds than those: the
  table is for how they move, not their level;
- the loading: the ledger's dust over the gas's mass (sum of density x cell volume x gas volume
  fraction over the fluid cells);
- each dust class's exit rate E_k = (mass it let out) / (integral of its hold-up dt), from
  result.json's dust_ledger.history, and its mean hold-up.

    /usr/bin/python3 bench/dust_exit_by_load.py RUN_DIR [--edges-ms 90,100,...] [--max-um 2.5]
Default intervals: between the run's hold-up fills, then to its end. Needs python3-h5py.
"""
import argparse
import json
import pathlib
import sys

import h5py
import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).parent))
from rates_by_interval import interval_bounds  # noqa: E402

RADII_MM = [5.0, 7.5, 10.0, 15.0]


def gas_cell_polar(scene, shape):
    """The gas grid's cell centres about the mill's axis, for cells of shape (z, y, x): radius
    and radial unit vector (y, x), cell-centre heights (z) and the cell size (x, y, z)."""
    lo, hi = np.array(scene["domain"]["min_m"]), np.array(scene["domain"]["max_m"])
    centre = np.array(scene["mill"]["center_xy_m"])
    nz, ny, nx = shape
    h = (hi - lo) / np.array([nx, ny, nz])
    xs = lo[0] + (np.arange(nx) + 0.5) * h[0] - centre[0]
    ys = lo[1] + (np.arange(ny) + 0.5) * h[1] - centre[1]
    X, Y = np.meshgrid(xs, ys)  # (y, x)
    r = np.hypot(X, Y)
    with np.errstate(invalid="ignore", divide="ignore"):
        ex, ey = X / r, Y / r
    zs = lo[2] + (np.arange(nz) + 0.5) * h[2]
    return r, ex, ey, zs, h


def ring_geometry(scene, shape, radii_mm):
    """The gas grid's radial and tangential unit vectors (y, x), each ring's cells below the
    outlet tube's mouth (z, y, x) and the cell volume, for cells of shape (z, y, x)."""
    lo, hi = np.array(scene["domain"]["min_m"]), np.array(scene["domain"]["max_m"])
    r, ex, ey, zs, h = gas_cell_polar(scene, shape)
    below_outlet = zs < hi[2] - lo[2] - scene["mill"]["outlet"]["depth_m"]
    rings = {x: (np.abs(r - x * 1e-3) < 0.5 * h[0])[None, :, :] & below_outlet[:, None, None]
             for x in radii_mm}
    return ex, ey, rings, float(np.prod(h))


def vortex_and_gas_mass(f, scene, radii_mm):
    """Per gas snapshot: time, {radius: (u_t, u_r, mean gas density there)}, gas mass (kg)."""
    rows, geometry = [], None
    for name in sorted(f["snapshots"].keys(), key=lambda s: f["snapshots"][s].attrs["time_s"]):
        g = f["snapshots"][name]
        if "gas_velocity" not in g:
            continue
        u = g["gas_velocity"][:]  # (z, y, x, 3)
        if geometry is None:
            geometry = ring_geometry(scene, u.shape[:3], radii_mm)
        ex, ey, rings, cell_volume = geometry
        fluid = g["gas_fluid"][:] > 0
        density = g["gas_density"][:] if "gas_density" in g else None
        fraction = g["gas_volume_fraction"][:]
        gas_mass = float(np.sum(density * fraction * fluid) * cell_volume) if density is not None \
            else float("nan")
        ring = {}
        for radius_mm in radii_mm:
            sel = fluid & rings[radius_mm]
            if not sel.any():
                ring[radius_mm] = (float("nan"), float("nan"), float("nan"))
                continue
            ut = (-ey[None] * u[..., 0] + ex[None] * u[..., 1])[sel]
            ur = (ex[None] * u[..., 0] + ey[None] * u[..., 1])[sel]
            rho = density[sel].mean() if density is not None else 1.2
            ring[radius_mm] = (float(ut.mean()), float(ur.mean()), float(rho))
        rows.append((g.attrs["time_s"], ring, gas_mass))
    return rows


def cut_size_m(mu, rho_p, rho_g, ut, ur, radius_m):
    if not (ut * ut > 0.0):
        return float("nan")
    return float(np.sqrt(18.0 * mu * abs(ur) * radius_m / ((rho_p - rho_g) * ut * ut)))


def history_span(t, t0, t1):
    """The first and last rows of the history's times t inside (t0, t1]."""
    return np.searchsorted(t, t0 + 1e-9), np.searchsorted(t, t1 + 1e-9) - 1


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("run_dir")
    ap.add_argument("--edges-ms", help="interval bounds in ms, comma-separated")
    ap.add_argument("--max-um", type=float, default=2.5, help="the coarsest dust class shown")
    ap.add_argument("--snapshots-from-ms", type=float,
                    help="also list every gas snapshot from this time: ledger, u_t, cut")
    a = ap.parse_args()
    r = json.load(open(f"{a.run_dir}/result.json"))
    scene = json.load(open(f"{a.run_dir}/scene.json"))
    bounds = interval_bounds(r, a.edges_ms)
    hist = r["dust_ledger"]["history"]
    t = np.array(hist["time_s"])
    held = np.array(hist["held_by_class_kg"])  # (classes, times)
    out = np.array(hist["outflow_by_class_kg"])
    total_held, total_out = np.array(hist["held_kg"]), np.array(hist["outflow_kg"])
    diam = np.array([c["diameter_m"] for c in r["dust_ledger"]["classes"]])
    shown = [k for k in range(len(diam)) if diam[k] <= a.max_um * 1e-6 and held[k].max() > 0]

    f = h5py.File(f"{a.run_dir}/run.h5", "r")
    outlet_mm = scene["mill"]["outlet"]["radius_m"] * 1e3
    radii = sorted(set(RADII_MM) | {outlet_mm})
    gas_rows = vortex_and_gas_mass(f, scene, radii)
    gt = np.array([row[0] for row in gas_rows])
    mu = scene["gas"]["viscosity_pa_s"]
    rho_p = scene["materials"][0]["density_kg_per_m3"]

    print("The vortex and the dust's loading, interval by interval (gas snapshots inside it):")
    print()
    print("| interval (ms) | ledger (mg) | gas (mg) | loading | "
          + " | ".join(f"u_t at {x:g} mm (m/s)" for x in radii)
          + f" | u_r at {outlet_mm:g} mm (m/s) | cut at {outlet_mm:g} mm (µm) | dust out (mg/s) |")
    print("| --- " * (len(radii) + 7) + "|")
    for t0, t1 in zip(bounds, bounds[1:]):
        inside = (gt > t0 + 1e-9) & (gt <= t1 + 1e-9)
        rows = [gas_rows[i] for i in np.nonzero(inside)[0]]
        if not rows:
            continue
        hs = (t > t0 + 1e-9) & (t <= t1 + 1e-9)
        ledger = total_held[hs].mean()
        gas = np.mean([row[2] for row in rows])
        ut = {x: np.mean([row[1][x][0] for row in rows]) for x in radii}
        ur_out = np.mean([row[1][outlet_mm][1] for row in rows])
        rho_out = np.mean([row[1][outlet_mm][2] for row in rows])
        cut = cut_size_m(mu, rho_p, rho_out, ut[outlet_mm], ur_out, outlet_mm * 1e-3)
        i0, i1 = history_span(t, t0, t1)
        rate = (total_out[i1] - total_out[i0]) / (t[i1] - t[i0]) if i1 > i0 else float("nan")
        print(f"| {t0 * 1e3:.1f}–{t1 * 1e3:.1f} | {ledger * 1e6:.2f} | {gas * 1e6:.2f} | "
              f"{ledger / gas:.3f} | " + " | ".join(f"{ut[x]:.1f}" for x in radii)
              + f" | {ur_out:.2f} | {cut * 1e6:.2f} | {rate * 1e6:.2f} |")

    if a.snapshots_from_ms is not None:
        print()
        print("| t (ms) | ledger (mg) | loading | "
              + " | ".join(f"u_t at {x:g} mm" for x in radii) + f" | cut at {outlet_mm:g} mm (µm) |")
        print("| --- " * (len(radii) + 4) + "|")
        for time_s, ring, gas in gas_rows:
            if time_s < a.snapshots_from_ms * 1e-3 - 1e-9:
                continue
            ledger = np.interp(time_s, t, total_held)
            ut, ur, rho = ring[outlet_mm]
            cut = cut_size_m(mu, rho_p, rho, ut, ur, outlet_mm * 1e-3)
            print(f"| {time_s * 1e3:.1f} | {ledger * 1e6:.3f} | {ledger / gas:.3f} | "
                  + " | ".join(f"{ring[x][0]:.1f}" for x in radii) + f" | {cut * 1e6:.3f} |")
    print()
    print("Each dust class's exit rate E (per second: what it let out over its hold-up's time "
          "integral) and its mean hold-up (µg, in brackets), interval by interval:")
    print()
    print("| interval (ms) | " + " | ".join(f"{diam[k] * 1e6:.2f} µm" for k in shown) + " |")
    print("| --- " * (len(shown) + 1) + "|")
    for t0, t1 in zip(bounds, bounds[1:]):
        i0, i1 = history_span(t, t0, t1)
        if i1 <= i0:
            continue
        cells = []
        for k in shown:
            integral = np.trapz(held[k][i0:i1 + 1], t[i0:i1 + 1])
            left = out[k][i1] - out[k][i0]
            mean = integral / (t[i1] - t[i0])
            cells.append(f"{left / integral:.3g} ({mean * 1e9:.0f})" if integral > 0 else "–")
        print(f"| {t[i0] * 1e3:.1f}–{t[i1] * 1e3:.1f} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
