#!/usr/bin/env bash
# Kill -9 loop (issue 18): a run of the attrition case (feeds, breakage, dust, an outlet) killed
# with SIGKILL at random moments, each time resumed with --resume, until it has been killed KILLS
# times; then it runs to its end. Its result.json physics must equal the run done in one go.
# Checkpoints come every 0.3 s of wall time, so some kills land during a checkpoint write (a
# leftover .tmp file shows it).
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
  "$millsim" run scene.json --out loop --quiet --resume --checkpoint-wall 0.3 >loop.json 2>>loop.err &
  pid=$!
  sleep "$(python3 -c "import random; print(round(random.uniform(0.2, 2.0), 3))")"
  if ! kill -0 "$pid" 2>/dev/null; then
    wait "$pid" || true
    break  # it finished before this kill
  fi
  kill -9 "$pid"
  wait "$pid" 2>/dev/null || true
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
print("identical physics" if a == b else "DIFFERENT: " + ", ".join(k for k in a if a[k] != b.get(k)))
sys.exit(0 if a == b else 1)
EOF
