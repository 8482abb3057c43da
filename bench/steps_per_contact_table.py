#!/usr/bin/env python3
"""The table of bench/steps_per_contact.sh: per run its step, time stepping (the sum of the phase
seconds, without the output), speed-up against the run of the same seed at the reference value,
product d10/d50/d90, breakage events by generation, the deepest overlap at the last step (in
diameters), the penetration limiter's events and the KS distance of its product (outlet + dust,
by mass) to the reference value's run of the same seed; then the reference value's own
seed-to-seed scatter (KS between every two seeds).

    python3 bench/steps_per_contact_table.py OUT_DIR REFERENCE_N
"""
import pathlib
import sys

from multi_rate_table import ks, load_runs, print_seed_scatter, stepping_s, um


def main():
    out, reference = pathlib.Path(sys.argv[1]), f"spc{sys.argv[2]}"
    runs = load_runs(out)
    print("| steps per contact | seed | step ns | time stepping s | speed-up | d10 / d50 / d90 um "
          "| events by generation | last max overlap / d | limiter events | KS to reference |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    order = lambda kv: (kv[0][1], -float(kv[0][0][3:]))
    for (name, seed), r in sorted(runs.items(), key=order):
        ref = runs.get((reference, seed))
        p = r["outlet_psd"]
        gens = r["breakage"].get("events_by_generation", [])
        overlap = r["contacts"].get("max_overlap_ratio", float("nan"))
        limiter = r["contacts"].get("penetration_limiter_events", 0)
        speed_up = stepping_s(ref) / stepping_s(r) if ref else float("nan")
        print(f"| {name[3:]} | {seed} | {r['time_step_s'] * 1e9:.2f} | {stepping_s(r):.1f} "
              f"| {speed_up:.2f} | {um(p['d10_m'])} / {um(p['d50_m'])} / {um(p['d90_m'])} "
              f"| {'/'.join(str(g) for g in gens)} | {overlap:.4f} "
              f"| {limiter} | {ks(r, ref) if ref else float('nan'):.4f} |")
    print_seed_scatter(runs, reference, f"{reference[3:]} steps per contact,")


if __name__ == "__main__":
    main()
