#!/usr/bin/python3
"""Whether a mill's breakage is first order: its particles' breakage rate per particle, by size,
interval by interval, against what the mill held (run.h5's event log and snapshots, result.json's
holdup_history). A hold-up fill that pools the particle rates over its windows
(time.fill_particle_rate_windows) assumes these rates do not move with the hold-up; the mean
specific impact energy of the events says whether the impacts softened.

    /usr/bin/python3 bench/rates_by_interval.py RUN_DIR [--edges-ms 20,30,...]
Default intervals: between the run's hold-up fills, then to its end. Needs python3-h5py.
"""
import argparse
import json

import h5py
import numpy as np

SIZE_GROUPS_UM = [50, 100, 200, 1e9]


def snapshot_counts(f, edges_m):
    """The snapshots' times and their particles counted into the size groups of edges_m."""
    snaps = sorted(f["snapshots"].keys(), key=lambda s: f["snapshots"][s].attrs["time_s"])
    times = np.array([f["snapshots"][s].attrs["time_s"] for s in snaps])
    counts = np.array([np.histogram(f["snapshots"][s]["diameter"][:], bins=edges_m)[0]
                       for s in snaps], dtype=float)
    return times, counts


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
    a = ap.parse_args()
    r = json.load(open(f"{a.run_dir}/result.json"))
    h = r["holdup_history"]
    bounds = interval_bounds(r, a.edges_ms)
    f = h5py.File(f"{a.run_dir}/run.h5", "r")
    edges = [x * 1e-6 for x in SIZE_GROUPS_UM]
    times, counts = snapshot_counts(f, edges)
    ev = f["breakage_events"]
    ev_t, ev_d = ev["time_s"][:], ev["parent_diameter_m"][:]
    ev_e = ev["specific_energy_j_per_kg"][:]
    names = [f"{lo:g}–{hi:g} µm" if hi < 1e8 else f"≥ {lo:g} µm"
             for lo, hi in zip(SIZE_GROUPS_UM, SIZE_GROUPS_UM[1:])]
    ht = np.array(h["time_s"])
    print("Breakage events per particle-second by size (events in brackets), the mean specific "
          "energy of the events (J/kg), and the mean hold-up, interval by interval:")
    print()
    print("| interval (ms) | particles held (mg) | ledger dust (mg) | "
          + " | ".join(names) + " | events | mean energy (J/kg) |")
    print("| --- " * (len(names) + 5) + "|")
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
        energy = np.mean(ev_e[sel]) if sel.any() else float("nan")
        print(f"| {ts[0] * 1e3:.1f}–{ts[-1] * 1e3:.1f} | {held:.2f} | {dust:.2f} | "
              + " | ".join(cells) + f" | {int(sel.sum())} ({sel.sum() / span * 1e-3 if span else 0:.1f}"
              f"/ms) | {energy:.0f} |")


if __name__ == "__main__":
    main()
