#!/usr/bin/env bash
# Copied from the team's shared/research/slurm-local.sh (the tested one-node Slurm recipe).
# slurm-local-stop.sh — stop exactly the daemons that slurm-local.sh started.
# Works from the pid files in $SLURM_LOCAL_DIR/run, and stops a munged whose command line names
# this directory's socket; never kills by process name alone.
# Order: cancel remaining jobs (so no slurmstepd outlives slurmd), then slurmrestd (if started),
# slurmd, slurmctld, slurmdbd and mariadbd (if started), munged.
# Each pid is checked against /proc/<pid>/comm before it is signalled (guards against pid reuse).
set -uo pipefail

DIR="${SLURM_LOCAL_DIR:-/tmp/slurm-local}"
export SLURM_CONF="$DIR/etc/slurm.conf"
export PATH="$PATH:/usr/sbin"
rc=0

alive() { [ -n "$1" ] && kill -0 "$1" 2>/dev/null; }

# 1. Cancel jobs still queued/running on this private cluster, wait for their steps to go.
ctld_pid="$(cat "$DIR/run/slurmctld.pid" 2>/dev/null || true)"
if [ -f "$SLURM_CONF" ] && alive "$ctld_pid"; then
  jobs="$(squeue -h -o %A 2>/dev/null | sort -u | tr '\n' ' ')"
  if [ -n "${jobs// /}" ]; then
    echo "[slurm-local-stop] cancelling jobs: $jobs" >&2
    # shellcheck disable=SC2086
    scancel $jobs 2>/dev/null || true
    for _ in $(seq 100); do
      [ -z "$(squeue -h -t all -o '%A %T' 2>/dev/null | grep -vE 'CANCELLED|COMPLETED|FAILED|TIMEOUT|NODE_FAIL|OUT_OF_MEMORY|BOOT_FAIL|DEADLINE|PREEMPTED')" ] && break
      sleep 0.2
    done
  fi
fi

stop_one() {  # name pidfile expected-comm
  local name="$1" f="$2" comm="$3" pid cur
  if [ ! -s "$f" ]; then return 0; fi   # not started in this mode
  pid="$(cat "$f")"
  if ! alive "$pid"; then echo "[slurm-local-stop] $name: pid $pid not running" >&2; rm -f "$f"; return 0; fi
  cur="$(cat "/proc/$pid/comm" 2>/dev/null || true)"
  if [ "$cur" != "$comm" ]; then
    echo "[slurm-local-stop] $name: pid $pid is '$cur', not '$comm' — leaving it alone" >&2; rc=1; return 0
  fi
  local t0; t0=$(date +%s%3N)
  kill -TERM "$pid"
  for _ in $(seq 100); do alive "$pid" || break; sleep 0.1; done
  if alive "$pid"; then
    echo "[slurm-local-stop] $name: pid $pid ignored SIGTERM for 10s, sending SIGKILL" >&2
    kill -KILL "$pid" 2>/dev/null || true; sleep 0.2
  fi
  alive "$pid" && { echo "[slurm-local-stop] $name: pid $pid still alive" >&2; rc=1; return 0; }
  rm -f "$f"
  echo "[slurm-local-stop] $name (pid $pid) stopped in $(( $(date +%s%3N) - t0 )) ms" >&2
}

stop_one slurmrestd "$DIR/run/slurmrestd.pid" slurmrestd
stop_one slurmd    "$DIR/run/slurmd.pid"    slurmd
stop_one slurmctld "$DIR/run/slurmctld.pid" slurmctld
stop_one slurmdbd  "$DIR/run/slurmdbd.pid"  slurmdbd     # only if SLURM_LOCAL_ACCOUNTING=1
stop_one mariadbd  "$DIR/run/mariadbd.pid"  mariadbd     # only if SLURM_LOCAL_ACCOUNTING=1
stop_one munged    "$DIR/run/munged.pid"    munged

# A munged of this directory whose pid file is gone (seen after a CI run: the daemon alive, its
# run/munged.pid missing, so the line above skipped it). It is found by its own command line,
# which names this directory's socket; no other process is touched.
for proc in /proc/[0-9]*; do
  [ "$(cat "$proc/comm" 2>/dev/null || true)" = munged ] || continue
  tr '\0' '\n' < "$proc/cmdline" 2>/dev/null | grep -qxF -- "--socket=$DIR/munge/munge.socket" || continue
  pid="${proc#/proc/}"
  orphan="$(mktemp)"
  printf '%s\n' "$pid" > "$orphan"
  echo "[slurm-local-stop] munged (pid $pid) serves $DIR without a pid file" >&2
  stop_one munged "$orphan" munged
  rm -f "$orphan"
done
exit $rc
