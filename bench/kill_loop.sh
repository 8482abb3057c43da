#!/usr/bin/env bash
# Kill -9 loop (issue 18): a run of the attrition case (feeds, breakage, dust, an outlet) killed
# with SIGKILL at random moments, each time resumed with --resume, until it has been killed KILLS
# times; then it runs to its end. Its result.json physics must equal the run done in one go.
# Checkpoints come every 0.3 s of wall time. Every fourth kill is aimed at a checkpoint write: a
# watcher sends SIGKILL the moment a checkpoint's temporary file appears (a leftover .tmp file
# after the kill shows that it landed during the write).
#   bash bench/kill_loop.sh [KILLS=20] [END_S=0.002]
set -euo pipefail
cd "$(dirname "$0")/.."
kills=${1:-20}
end_s=${2:-0.002}
millsim=$PWD/build/cli/millsim
work=$(mktemp -d /tmp/millsim-kill-loop.XXXXXX)
trap 'rm -rf "$work"' EXIT
python3 - "$work/scene.json" "$end_s" <<'EOF'
import json, sys
scene = json.load(open("cases/attrition_target.json"))
scene["time"]["end_s"] = float(sys.argv[2])
scene["output"] = {"snapshot_interval_s": float(sys.argv[2]) / 5}
json.dump(scene, open(sys.argv[1], "w"))
EOF
cd "$work"
start=$(date +%s.%N)
"$millsim" run scene.json --out whole --quiet --checkpoint-wall 0.3 >whole.json 2>/dev/null
echo "one go: $(python3 -c "print(round($(date +%s.%N) - $start, 1))") s"

killed=0
during_write=0
while [ "$killed" -lt "$kills" ]; do
  rm -f loop/checkpoints/*.tmp  # a write the last kill cut short
  "$millsim" run scene.json --out loop --quiet --resume --checkpoint-wall 0.3 >loop.json 2>>loop.err &
  pid=$!
  if [ $((killed % 4)) -eq 3 ]; then
    python3 - "$pid" <<'WATCH' || true
import glob, os, signal, sys, time
pid, end = int(sys.argv[1]), time.time() + 5.0
while time.time() < end:
    if glob.glob("loop/checkpoints/*.tmp"):
        os.kill(pid, signal.SIGKILL)
        break
WATCH
  else
    sleep "$(python3 -c "import random; print(round(random.uniform(0.2, 2.0), 3))")"
  fi
  kill -9 "$pid" 2>/dev/null || true
  status=0
  wait "$pid" 2>/dev/null || status=$?  # bash reports "Killed" on stderr
  if [ "$status" -ne 137 ]; then break; fi  # it ended on its own before this kill
  killed=$((killed + 1))
  if ls loop/checkpoints/*.tmp >/dev/null 2>&1; then during_write=$((during_write + 1)); fi
done
# Let the last attempt finish (or run one more when the loop ended on a kill).
if ! python3 -c "import json,sys; sys.exit(0 if json.load(open('loop.json')).get('status') == 'ok' else 1)" 2>/dev/null; then
  "$millsim" run scene.json --out loop --quiet --resume --checkpoint-wall 0.3 >loop.json 2>>loop.err
fi
python3 - "$killed" "$during_write" <<'EOF'
import json, sys
skip = {"wall_time_s", "wall_time_total_s", "particle_steps_per_second", "phase_seconds",
        "resumed", "checkpoints", "outputs"}
whole = json.load(open("whole.json"))
loop = json.load(open("loop.json"))
a = {k: v for k, v in whole.items() if k not in skip}
b = {k: v for k, v in loop.items() if k not in skip}
print(f"kills: {sys.argv[1]} (during a checkpoint write: {sys.argv[2]})")
print(f"resumed from step {loop['resumed']['step']} of {loop['steps']}; snapshots carried "
      f"{loop['resumed']['snapshots_carried']}, damaged checkpoints skipped "
      f"{len(loop['resumed']['skipped_damaged'])}")
print(f"breakage events {b['breakage']['events']}, outlet particles {b['outlet_particles']['count']}")
print(f"snapshots in run.h5: {loop['outputs']['snapshots']} (one go: {whole['outputs']['snapshots']})")
print("identical physics" if a == b else "DIFFERENT: " + ", ".join(k for k in a if a[k] != b.get(k)))
sys.exit(0 if a == b else 1)
EOF
