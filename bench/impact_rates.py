#!/usr/bin/python3
"""Why a size group of a mill run breaks as fast as it does: over a window of the run, per size
group, the particle-seconds held, the impacts met per particle-second by contact partner (the
chamber wall, other particles, the plates), those among them whose normal specific energy
v_n^2/2 reaches the strength threshold W_min(x) = (x W_min) / x of Vogel & Peukert at the class's
size x, and the breakage events on walls and between particles with the rate S they give
(events per particle-second).

    /usr/bin/python3 bench/impact_rates.py RUN_DIR [RUN_DIR ...] [--window-ms A B] [--groups-um 25,50,100,200,400]

The window defaults to the run's steady_projection window (its product window). Impacts come
from RUN_DIR/run.h5 /impact_spectrum/interval_normal_counts (interval x group x size x bin: the
intervals whose end lies in the window); the hold-up from result.json holdup_history
(particles_by_class_kg, each class's mass as spheres of its geometric-centre size, the feed
material's density from RUN_DIR/scene.json); the events from steady_projection.slots.particles
(`events`, `wall_events`), so they are shown only when the window is the projection's. A pair impact's energy
is that of the relative motion, not the strength model's wall-equivalent energy (docs/comminution.md,
"Impact statistics"): its column above W_min is a count of hard impacts, not of breakage chances.
Needs python3-h5py (Debian).
"""
import argparse
import json
import math

import h5py


def sphere_mass(d_m, density):
    return density * math.pi / 6.0 * d_m ** 3


def feed_density(scene):
    """The density (kg/m³) of the scene's first feed's material."""
    material = scene["feeds"][0]["material"]
    return next(m["density_kg_per_m3"] for m in scene["materials"] if m["name"] == material)


def strength_x_w_min(scene, material):
    m = next(m for m in scene["materials"] if m["name"] == material)
    return m["breakage"]["strength"]["x_w_min_j_m_per_kg"], m["density_kg_per_m3"]


def particle_seconds(history, centres_m, density, t0, t1):
    """Particle-seconds per PSD class over [t0, t1] by the trapezoid rule on holdup_history."""
    t, held = history["time_s"], history["particles_by_class_kg"]
    masses = [sphere_mass(d, density) for d in centres_m]
    counts = [0.0] * len(centres_m)
    for a in range(1, len(t)):
        lo, hi = max(t[a - 1], t0), min(t[a], t1)
        if hi <= lo:
            continue
        for k, m in enumerate(masses):  # held[.][0] is the underflow
            counts[k] += (hi - lo) * 0.5 * (held[a - 1][k + 1] + held[a][k + 1]) / m
    return counts


def report(run_dir, window_ms, groups_um):
    result = json.load(open(f"{run_dir}/result.json"))
    scene = json.load(open(f"{run_dir}/scene.json"))
    projection = result.get("steady_projection") or {}
    if window_ms:
        t0, t1 = window_ms[0] * 1e-3, window_ms[1] * 1e-3
    else:
        t0, t1 = projection["window_s"]
    slots = projection.get("slots", {}).get("particles", {})
    if [t0, t1] != projection.get("window_s"):
        slots = {}  # its events are the projection window's, not this one's
    feed_material = scene["feeds"][0]["material"]
    x_w_min, density = strength_x_w_min(scene, feed_material)
    with h5py.File(f"{run_dir}/run.h5", "r") as f:
        spectrum = f["impact_spectrum"]
        energy = spectrum["energy_edges_j_per_kg"][()]
        size = spectrum["size_edges_m"][()]
        ends = spectrum["interval_end_s"][()]
        names = [n for n in spectrum.attrs["groups"].split("\n") if n]
        rows = [i for i, e in enumerate(ends) if t0 < e <= t1 + 1e-9]
        counts = spectrum["interval_normal_counts"][rows[0]:rows[-1] + 1].sum(axis=0)
    centres = [math.sqrt(a * b) for a, b in zip(size, size[1:])]
    held = particle_seconds(result["holdup_history"], centres, density, t0, t1)
    print(f"## {run_dir}: {ends[rows[0]] * 1e3 - 1:.0f}-{ends[rows[-1]] * 1e3:.0f} ms "
          f"({len(rows)} intervals), x W_min {x_w_min} J m/kg, density {density:g} kg/m3")
    print("| group (um) | particle-s | partner | impacts per particle-s | of them >= W_min(x) |")
    print("| --- | --- | --- | --- | --- |")
    for lo, hi in zip(groups_um, groups_um[1:]):
        classes = [k for k, d in enumerate(centres) if lo * 1e-6 <= d < hi * 1e-6]
        seconds = sum(held[k] for k in classes)
        if seconds <= 0:
            print(f"| {lo:g}-{hi:g} | 0 | | | |")
            continue
        for g, name in enumerate(names):
            total = hard = 0
            for k in classes:
                w_min = x_w_min / centres[k]
                total += int(counts[g][k].sum())
                hard += int(sum(c for j, c in enumerate(counts[g][k]) if energy[j] >= w_min))
            print(f"| {lo:g}-{hi:g} | {seconds:.4g} | {name} | {total / seconds:.4g} | {hard / seconds:.4g} |")
        if slots:
            in_group = [k + 1 for k in classes]  # slot 0 is the underflow
            events = sum(slots["events"][s] for s in in_group)
            wall = sum(slots["wall_events"][s] for s in in_group)
            print(f"| {lo:g}-{hi:g} | | breakage events: {events:.0f}, on walls "
                  f"{wall:.0f} | S = {events / seconds:.3g} /s | |")
    print()


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+")
    ap.add_argument("--window-ms", type=float, nargs=2, help="default: steady_projection.window_s")
    ap.add_argument("--groups-um", default="25,50,100,200,400")
    a = ap.parse_args()
    groups = [float(x) for x in a.groups_um.split(",")]
    for run in a.runs:
        report(run, a.window_ms, groups)


if __name__ == "__main__":
    main()
