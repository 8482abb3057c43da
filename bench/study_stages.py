#!/usr/bin/env python3
"""Stage table of a study run with `millsim study --local` (the acceleration chain, a dust scan).

For each run, in study order: its label (from --labels, or its parameters), the time-stepping
wall time, steps, time step, particle-steps, particles at the end, breakage events and
generations, the product's d10/d50/d90 (outlet + dust), the study's error against its
reference, and the speed-up against the reference run and against the run before.

    python3 bench/study_stages.py OUT/studies/SXXXXXX [--labels "a,b,c"] [--markdown]

With --factors the time is the time stepping alone (the sum of the phases: no gas spin-up, no
output), given per simulated microsecond, and each run's speed-up against the reference splits
exactly into its three factors: steps (the time step), mean particles per step (particle-steps
over steps), and cost per particle-step.
"""
import argparse
import json
import os


def study_runs(args):
    """Each run of the study in order: its label, its row of results.json and its result.json
    (None while it has none)."""
    table = json.load(open(os.path.join(args.study_dir, "results.json")))
    labels = [s for s in args.labels.split(",") if s]
    for k, run in enumerate(table["runs"]):
        path = os.path.join(args.study_dir, run["run"], "result.json")
        label = labels[k] if k < len(labels) else " ".join(
            f"{p.split('.')[-1]}={v}" for p, v in run["params"].items())
        yield label, run, json.load(open(path)) if os.path.exists(path) else None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("study_dir")
    ap.add_argument("--labels", default="")
    ap.add_argument("--markdown", action="store_true")
    ap.add_argument("--reverse", action="store_true", help="list the runs last to first")
    ap.add_argument("--factors", action="store_true",
                    help="time stepping per simulated us, and the speed-up's three factors")
    args = ap.parse_args()
    if args.factors:
        return print_factors(args)
    rows = []
    for label, run, r in study_runs(args):
        if r is None:
            rows.append({"label": label, "state": run["state"], "reference": run.get("reference")})
            continue
        b = r.get("breakage", {})
        rows.append({
            "label": label, "state": run["state"], "wall_s": r["wall_time_s"], "steps": r["steps"],
            "dt_s": r["time_step_s"],
            "psteps": r["particle_steps_per_second"] * r["wall_time_s"],
            "particles": r["particles"]["final"], "events": b.get("events", 0),
            "generations": len(b.get("events_by_generation", [])),
            "d10": r["outlet_psd"]["d10_m"] * 1e6, "d50": r["outlet_psd"]["d50_m"] * 1e6,
            "d90": r["outlet_psd"]["d90_m"] * 1e6, "error": run.get("error"),
            "reference": run.get("reference"),
        })
    if args.reverse:
        rows.reverse()
    ref = next((i for i, row in enumerate(rows) if row["reference"]), 0)
    head = ["stage", "wall s", "steps", "dt s", "particle-steps", "particles", "events", "gen",
            "d10 um", "d50 um", "d90 um", "error", "x vs ref", "x vs prev"]  # speed-ups: wall time of the reference / previous row over this row's
    out = []
    for k, row in enumerate(rows):
        if "wall_s" not in row:
            out.append([row["label"], row["state"]] + [""] * (len(head) - 2))
            continue
        ref_wall = rows[ref].get("wall_s")
        prev_wall = rows[k - 1].get("wall_s") if k > 0 else None
        out.append([
            row["label"], f"{row['wall_s']:.2f}", str(row["steps"]), f"{row['dt_s']:.3g}",
            f"{row['psteps']:.3g}", str(row["particles"]), str(row["events"]), str(row["generations"]),
            f"{row['d10']:.2f}", f"{row['d50']:.2f}", f"{row['d90']:.2f}",
            "" if row["error"] is None else f"{row['error']:.4f}",
            f"{ref_wall / row['wall_s']:.1f}" if ref_wall else "",
            f"{prev_wall / row['wall_s']:.2f}" if prev_wall else "",
        ])
    if args.markdown:
        print("| " + " | ".join(head) + " |")
        print("| " + " | ".join("---" for _ in head) + " |")
        for line in out:
            print("| " + " | ".join(line) + " |")
    else:
        widths = [max(len(h), *(len(line[i]) for line in out)) for i, h in enumerate(head)]
        print("  ".join(h.ljust(w) for h, w in zip(head, widths)))
        for line in out:
            print("  ".join(c.ljust(w) for c, w in zip(line, widths)))


def print_factors(args):
    rows = []
    for label, run, r in study_runs(args):
        if r is None:
            continue
        stepping = sum(r["phase_seconds"].values())
        psteps = r["particle_steps_per_second"] * stepping
        rows.append({
            "label": label, "reference": run.get("reference"),
            "us": r["simulated_time_s"] * 1e6, "stepping": stepping, "steps": r["steps"],
            "dt": r["time_step_s"], "mean_particles": psteps / r["steps"],
            "final": r["particles"]["final"], "ns_per_pstep": 1e9 * stepping / psteps,
            "error": run.get("error"),
        })
    if args.reverse:
        rows.reverse()
    ref = next((row for row in rows if row["reference"]), rows[0])
    head = ["stage", "s per sim. us", "steps", "dt ns", "mean particles", "particles at end",
            "ns per particle-step", "speed-up", "= steps", "x particles", "x cost", "error"]
    print("| " + " | ".join(head) + " |")
    print("| " + " | ".join("---" for _ in head) + " |")
    for row in rows:
        steps_f = ref["steps"] / row["steps"]
        particles_f = ref["mean_particles"] / row["mean_particles"]
        cost_f = ref["ns_per_pstep"] / row["ns_per_pstep"]
        cells = [row["label"], f"{row['stepping'] / row['us']:.4g}", str(row["steps"]),
                 f"{row['dt'] * 1e9:.3g}", f"{row['mean_particles']:.0f}", str(row["final"]),
                 f"{row['ns_per_pstep']:.1f}", f"{steps_f * particles_f * cost_f:.1f}",
                 f"{steps_f:.2f}", f"{particles_f:.2f}", f"{cost_f:.2f}",
                 "" if row["error"] is None else f"{row['error']:.4f}"]
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
