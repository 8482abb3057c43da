#!/usr/bin/env python3
"""The table of bench/wall_riders.sh: per run its time stepping (the sum of the phase seconds,
without the gas spin-up and the output), the DEM's part of it (without the gas phase), the
riders' time, particles and wall contacts at the end, breakage events by generation, the riders'
own steps and the riders on each level at the end, and the KS distance of its outlet PSD (outlet
+ dust, by mass) to the run without riders of the same seed.

    python3 bench/wall_riders_table.py OUT_DIR
"""
import pathlib
import sys

from multi_rate_table import ks, load_runs, stepping_s


def times(r):
    total = stepping_s(r)
    return total, total - r["phase_seconds"].get("gas", 0.0)


def main():
    runs = load_runs(pathlib.Path(sys.argv[1]))
    print("| riders | seed | time stepping s | DEM s (no gas) | DEM speed-up | wall riders s "
          "| particles at end | wall contacts at end | events by generation "
          "| own steps | riders on levels 1-6 at end | KS to off |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for (name, seed), r in sorted(runs.items(), key=lambda kv: (kv[0][1], kv[0][0] != "riders_off")):
        off = runs.get(("riders_off", seed))
        total, dem = times(r)
        speed_up = times(off)[1] / dem if off else float("nan")
        mr = r.get("multi_rate", {})
        riders = mr.get("wall_riders", {})
        gens = r.get("breakage", {}).get("events_by_generation", [])
        contacts = r.get("contacts", {})
        print(f"| {name.split('_')[1]} | {seed} | {total:.1f} | {dem:.1f} | {speed_up:.2f} "
              f"| {r['phase_seconds'].get('wall_riders', 0.0):.1f} "
              f"| {r['particles']['final']} "
              f"| {contacts.get('walls', '?')} | {'/'.join(str(g) for g in gens)} "
              f"| {riders.get('own_steps', 0):.3g} "
              f"| {'/'.join(str(n) for n in riders.get('riders_by_level_at_end', []))} "
              f"| {ks(r, off) if off else float('nan'):.4f} |")


if __name__ == "__main__":
    main()
