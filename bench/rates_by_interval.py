#!/usr/bin/python3
"""Whether a mill's breakage is first order: its particles' breakage rate per particle, by size,
interval by interval, against what the mill held (run.h5's event log and snapshots, result.json's
holdup_history). A hold-up fill that pools the particle rates over its windows
(time.fill_particle_rate_windows) assumes these rates do not move with the hold-up; the mean
specific impact energy of the events says whether the impacts softened.

    /usr/bin/python3 bench/rates_by_interval.py RUN_DIR [--edges-ms 20,30,...] [--groups-um 50,100,200]
Default intervals: between the run's hold-up fills, then to its end. A second table is each size
group's mass balance over the intervals: the mass it held (snapshots, spheres of the feed
material's density), its breakage throughput (the parents' mass broken per second), its growth,
and the inflow they imply (throughput + growth: what breakage of coarser particles and the feed
sent into it). Needs python3-h5py.
"""
import argparse
import json

import h5py
import numpy as np

from impact_rates import feed_density, sphere_mass


def snapshot_counts(f, edges_m, density):
    """The snapshots' times, their particles counted into the size groups of edges_m, and the
    groups' masses (kg)."""
    snaps = sorted(f["snapshots"].keys(), key=lambda s: f["snapshots"][s].attrs["time_s"])
    times = np.array([f["snapshots"][s].attrs["time_s"] for s in snaps])
    diameters = [f["snapshots"][s]["diameter"][:] for s in snaps]
    counts = np.array([np.histogram(d, bins=edges_m)[0] for d in diameters], dtype=float)
    masses = np.array([np.histogram(d, bins=edges_m, weights=sphere_mass(d, density))[0]
                       for d in diameters])
    return times, counts, masses


def particle_seconds(times, counts):
    """Particle-seconds per size group: the trapezoid over the snapshots given."""
    exposure = np.zeros(counts.shape[1])
    for k in range(1, len(times)):
        exposure += 0.5 * (counts[k] + counts[k - 1]) * (times[k] - times[k - 1])
    return exposure


def interval_bounds(result, edges_ms):
    """Interval bounds in s: edges_ms (comma-separated ms) when given, else the run's filled
    hold-up fills and its end."""
    if edges_ms:
        return [float(x) * 1e-3 for x in edges_ms.split(",")]
    bounds = [f["time_s"] for f in result.get("holdup_fills") or [] if f.get("status") == "filled"]
    return bounds + [result["simulated_time_s"]]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("run_dir")
    ap.add_argument("--edges-ms", help="interval bounds in ms, comma-separated")
    ap.add_argument("--groups-um", default="50,100,200",
                    help="lower edges of the size groups in µm; the last group is open above")
    a = ap.parse_args()
    groups_um = [float(x) for x in a.groups_um.split(",")] + [1e9]
    r = json.load(open(f"{a.run_dir}/result.json"))
    h = r["holdup_history"]
    bounds = interval_bounds(r, a.edges_ms)
    density = feed_density(json.load(open(f"{a.run_dir}/scene.json")))
    f = h5py.File(f"{a.run_dir}/run.h5", "r")
    edges = [x * 1e-6 for x in groups_um]
    times, counts, masses = snapshot_counts(f, edges, density)
    ev = f["breakage_events"]
    ev_t, ev_d = ev["time_s"][:], ev["parent_diameter_m"][:]
    ev_e = ev["specific_energy_j_per_kg"][:]
    names = [f"{lo:g}–{hi:g} µm" if hi < 1e8 else f"≥ {lo:g} µm"
             for lo, hi in zip(groups_um, groups_um[1:])]
    ht = np.array(h["time_s"])
    print("Breakage events per particle-second by size (events in brackets), the mean specific "
          "energy of the events (J/kg), and the mean hold-up, interval by interval:")
    print()
    print("| interval (ms) | particles held (mg) | ledger dust (mg) | "
          + " | ".join(names) + " | events | mean energy (J/kg) |")
    print("| --- " * (len(names) + 5) + "|")
    balance = []
    for t0, t1 in zip(bounds, bounds[1:]):
        inside = (times >= t0 - 1e-9) & (times <= t1 + 1e-9)
        ts = times[inside]
        exposure = particle_seconds(ts, counts[inside])
        span = ts[-1] - ts[0] if len(ts) > 1 else 0.0
        sel = (ev_t >= ts[0]) & (ev_t < ts[-1]) if len(ts) > 1 else np.zeros_like(ev_t, bool)
        events = np.histogram(ev_d[sel], bins=edges)[0]
        rows = (ht >= t0 - 1e-9) & (ht <= t1 + 1e-9)
        held = np.mean(np.array(h["particles_kg"])[rows]) * 1e6
        dust = np.mean(np.array(h["dust_held_kg"])[rows]) * 1e6
        cells = [f"{e / x:.2f} ({e})" if x > 0 else "–" for e, x in zip(events, exposure)]
        if span > 0:
            broken = np.histogram(ev_d[sel], bins=edges, weights=sphere_mass(ev_d[sel], density))[0]
            group_mass = masses[inside]
            balance.append((ts[0], ts[-1], particle_seconds(ts, group_mass) / span, broken / span,
                            (group_mass[-1] - group_mass[0]) / span))
        energy = np.mean(ev_e[sel]) if sel.any() else float("nan")
        print(f"| {ts[0] * 1e3:.1f}–{ts[-1] * 1e3:.1f} | {held:.2f} | {dust:.2f} | "
              + " | ".join(cells) + f" | {int(sel.sum())} ({sel.sum() / span * 1e-3 if span else 0:.1f}"
              f"/ms) | {energy:.0f} |")
    print()
    print("Each group's mass balance (mg held, mean over the interval; mg/s broken as parents, "
          "growth, and inflow = broken + growth):")
    print()
    print("| interval (ms) | " + " | ".join(f"{n}: held / broken / growth / inflow" for n in names)
          + " |")
    print("| --- " * (len(names) + 1) + "|")
    for t0, t1, held_mean, broken, growth in balance:
        cells = [f"{m * 1e6:.2f} / {b * 1e6:.2f} / {g * 1e6:+.2f} / {(b + g) * 1e6:.2f}"
                 for m, b, g in zip(held_mean, broken, growth)]
        print(f"| {t0 * 1e3:.1f}–{t1 * 1e3:.1f} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
