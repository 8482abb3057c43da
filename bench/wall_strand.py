#!/usr/bin/python3
"""The strand of particles along a mill's chamber wall, from a run's snapshots: over a window, for
one size group, how much of it rides the wall, how fast it runs round, how often a member near
the wall moves outward at least as fast as its strength threshold asks (v_r^2/2 >= W_min(x) =
(x W_min) / x, Vogel & Peukert: a hard wall impact on its way), by tangential speed, and what
surrounds it (particles of any size within 0.5 mm, the mass of particles >= 50 um within 0.5 mm of
the wall, the gas's tangential speed in the outer 2.5 mm). It measures from positions and
velocities what bench/impact_rates.py counts from the impact spectrum, which has no radius.

    /usr/bin/python3 bench/wall_strand.py RUN_DIR [RUN_DIR ...] [--window-ms A B] [--group-um 50 100]

The window defaults to the run's steady_projection window. A particle is "near the wall" when
the gap between its surface and the chamber's mantle is below 0.5 mm. Snapshots are instants:
the counts are per particle-snapshot, not per second. Needs python3-h5py, python3-scipy (Debian).
"""
import argparse
import json

import h5py
import numpy as np
from scipy.spatial import cKDTree

from dust_exit_by_load import gas_cell_polar
from impact_rates import strength_x_w_min

NEAR_WALL_M = 0.5e-3
NEIGHBOUR_RADIUS_M = 0.5e-3
GAS_RING_M = 2.5e-3
SPEED_BANDS_M_PER_S = [0, 5, 10, 15, 20, 25, 30, 1e9]


def cylindrical(position, velocity, centre):
    dx, dy = position[:, 0] - centre[0], position[:, 1] - centre[1]
    r = np.hypot(dx, dy)
    v_r = (velocity[:, 0] * dx + velocity[:, 1] * dy) / r
    v_t = (-velocity[:, 0] * dy + velocity[:, 1] * dx) / r
    return r, v_r, v_t


def outer_ring(scene, shape, radius):
    """The gas cells' radial unit vectors (y, x) and the cells (y, x) whose centre lies in the
    outer GAS_RING_M of the chamber, for cells of shape (z, y, x)."""
    r, ex, ey, _, _ = gas_cell_polar(scene, shape)
    return ex, ey, (r > radius - GAS_RING_M) & (r < radius)


def gas_tangential_in_ring(snapshot, ring_cells):
    """Tangential gas speeds of the fluid cells of ring_cells (outer_ring's answer)."""
    ex, ey, ring = ring_cells
    velocity = snapshot["gas_velocity"][()]
    fluid = snapshot["gas_fluid"][()] > 0.5
    v_t = -ey[None] * velocity[..., 0] + ex[None] * velocity[..., 1]
    return v_t[fluid & ring[None]]


def report(run_dir, window_ms, group_um):
    result = json.load(open(f"{run_dir}/result.json"))
    scene = json.load(open(f"{run_dir}/scene.json"))
    t0, t1 = ([w * 1e-3 for w in window_ms] if window_ms
              else result["steady_projection"]["window_s"])
    x_w_min, density = strength_x_w_min(scene, scene["feeds"][0]["material"])
    centre, radius = scene["mill"]["center_xy_m"], scene["mill"]["radius_m"]
    lo, hi = group_um[0] * 1e-6, group_um[1] * 1e-6
    members = near = outward = hard = 0
    near_by_band = np.zeros(len(SPEED_BANDS_M_PER_S) - 1)
    hard_by_band = np.zeros(len(SPEED_BANDS_M_PER_S) - 1)
    v_t_near, neighbours, coarse_at_wall_kg, gas_v_t = [], [], [], []
    with h5py.File(f"{run_dir}/run.h5", "r") as f:
        snapshots = [s for s in f["snapshots"].values() if t0 <= s.attrs["time_s"] <= t1 + 1e-9]
        ring_cells = outer_ring(scene, snapshots[0]["gas_fluid"].shape, radius) if snapshots else None
        for s in snapshots:
            d, p, v = s["diameter"][()], s["position"][()], s["velocity"][()]
            r, v_r, v_t = cylindrical(p, v, centre)
            gap = radius - r - 0.5 * d
            in_group = (d >= lo) & (d < hi)
            at_wall = in_group & (gap < NEAR_WALL_M)
            is_hard = at_wall & (v_r > 0) & (0.5 * v_r**2 >= x_w_min / d)
            members += in_group.sum()
            near += at_wall.sum()
            outward += (at_wall & (v_r > 0)).sum()
            hard += is_hard.sum()
            near_by_band += np.histogram(v_t[at_wall], bins=SPEED_BANDS_M_PER_S)[0]
            hard_by_band += np.histogram(v_t[is_hard], bins=SPEED_BANDS_M_PER_S)[0]
            v_t_near.append(v_t[at_wall])
            if at_wall.any():
                counts = cKDTree(p).query_ball_point(p[at_wall], NEIGHBOUR_RADIUS_M,
                                                     return_length=True)
                neighbours.append(counts - 1)
            coarse = (d >= 50e-6) & (gap < NEAR_WALL_M)
            coarse_at_wall_kg.append(density * np.pi / 6.0 * np.sum(d[coarse] ** 3))
            gas_v_t.append(gas_tangential_in_ring(s, ring_cells))
    if members == 0:
        print(f"## {run_dir}: no {group_um[0]:g}-{group_um[1]:g} um particles in the window\n")
        return
    v_t_near = np.concatenate(v_t_near)
    neighbours = np.concatenate(neighbours) if neighbours else np.zeros(1)
    gas_v_t = np.concatenate(gas_v_t)
    print(f"## {run_dir}: {t0 * 1e3:.0f}-{t1 * 1e3:.0f} ms, {len(snapshots)} snapshots, "
          f"{group_um[0]:g}-{group_um[1]:g} um, x W_min {x_w_min} J m/kg")
    print(f"- members per snapshot {members / len(snapshots):.0f}, near the wall {near / members:.3f}, "
          f"of those moving outward {outward / max(near, 1):.3f}")
    print(f"- near the wall, tangential speed median {np.median(v_t_near):.1f} m/s, "
          f"90th percentile {np.percentile(v_t_near, 90):.1f} m/s")
    print(f"- moving outward near the wall with v_r^2/2 >= W_min(x): {hard} "
          f"({1e3 * hard / members:.3g} per 1000 member-snapshots)")
    print(f"- particles of any size within {NEIGHBOUR_RADIUS_M * 1e3:g} mm of a member near the "
          f"wall: median {np.median(neighbours):.0f}, mean {neighbours.mean():.1f}")
    print(f"- particles >= 50 um near the wall {np.mean(coarse_at_wall_kg) * 1e9:.0f} ug; gas "
          f"tangential speed in the outer {GAS_RING_M * 1e3:g} mm median {np.median(gas_v_t):.1f} m/s")
    print("| tangential speed (m/s) | share of the group near the wall | hard outward per 1000 of them |")
    print("| --- | --- | --- |")
    for b, (a, c) in enumerate(zip(SPEED_BANDS_M_PER_S, SPEED_BANDS_M_PER_S[1:])):
        band = f"{a:g}-{c:g}" if c < 1e9 else f">= {a:g}"
        rate = 1e3 * hard_by_band[b] / near_by_band[b] if near_by_band[b] else 0.0
        print(f"| {band} | {near_by_band[b] / members:.4f} | {rate:.2f} |")
    print()


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+")
    ap.add_argument("--window-ms", type=float, nargs=2, help="default: steady_projection.window_s")
    ap.add_argument("--group-um", type=float, nargs=2, default=[50.0, 100.0])
    a = ap.parse_args()
    for run in a.runs:
        report(run, a.window_ms, a.group_um)


if __name__ == "__main__":
    main()
