#!/usr/bin/env bash
# Copied from the team's shared/research/slurm-local.sh (the tested one-node Slurm recipe).
# slurm-local.sh — start a throw-away, single-node Slurm "cluster" on this host
# (munged + slurmctld + slurmd), for CI tests of a 'slurm' executor.
#
# Needs (Debian 12, Slurm 22.05.8):
#   apt-get install -y --no-install-recommends slurmctld slurmd slurm-client munge   (~45 MB)
#   (`apt-get install slurm-wlm munge` works too, but with recommends pulls ~1.5 GB)
# Measured on a 2-core gVisor container: start to "node idle" in 0.3-0.7 s (2.7 s with
# SLURM_LOCAL_ACCOUNTING=1); stop ~8 s (each daemon takes 1-3 s to exit on SIGTERM).
#
# CI pattern:   bash slurm-local.sh && trap 'bash slurm-local-stop.sh' EXIT
#               export SLURM_CONF=/tmp/slurm-local/etc/slurm.conf
#
# Everything lives in $SLURM_LOCAL_DIR (default /tmp/slurm-local): config, munge key and
# socket, controller state, spool, logs, pid files. Nothing under /etc is touched, no
# systemd is used, no cgroups are needed (proctrack/linuxproc, task/none).
# Daemons run as the invoking user (root in CI containers).
#
# Usage:   slurm-local.sh            start, wait until the node is idle, print env line
#          slurm-local-stop.sh       stop exactly the daemons started here (by pid file)
# Then:    export SLURM_CONF="$SLURM_LOCAL_DIR/etc/slurm.conf"; sbatch --wrap 'hostname'
#
# Tunables (env): SLURM_LOCAL_DIR, SLURM_LOCAL_CTLD_PORT (6817), SLURM_LOCAL_SLURMD_PORT (6818),
#                 SLURM_LOCAL_TIMEOUT (seconds to wait for idle node, 60),
#                 SLURM_LOCAL_CPUS (nproc), SLURM_LOCAL_MEM_MB (from slurmd -C, minus 10%),
#                 SLURM_LOCAL_RESTD = none (default) | unix | tcp :
#                   unix: slurmrestd on $DIR/run/slurmrestd.sock, rest_auth/local (caller's uid)
#                   tcp:  slurmrestd on 127.0.0.1:$SLURM_LOCAL_RESTD_PORT (6820), rest_auth/jwt;
#                         turns on AuthAltTypes=auth/jwt (needs package slurm-wlm-jwt-plugin);
#                         get a token with:  scontrol token lifespan=3600
#                   (both need package slurmrestd; API version served by Debian 12: v0.0.38)
#                 SLURM_LOCAL_ACCOUNTING = 0 (default) | 1 :
#                   1: also start a private MariaDB (127.0.0.1:$SLURM_LOCAL_DB_PORT, 3307) and
#                      slurmdbd (127.0.0.1:$SLURM_LOCAL_DBD_PORT, 6819) so that `sacct` works
#                      (needs packages slurmdbd mariadb-server, ~200 MB). Without it, sacct says
#                      "Slurm accounting storage is disabled"; use `sacct -c` (jobcomp file),
#                      `squeue -t all` or `scontrol show job` instead (finished jobs stay MinJobAge=600 s).
set -euo pipefail

DIR="${SLURM_LOCAL_DIR:-/tmp/slurm-local}"
CTLD_PORT="${SLURM_LOCAL_CTLD_PORT:-6817}"
SLURMD_PORT="${SLURM_LOCAL_SLURMD_PORT:-6818}"
TIMEOUT="${SLURM_LOCAL_TIMEOUT:-60}"
RESTD="${SLURM_LOCAL_RESTD:-none}"
RESTD_PORT="${SLURM_LOCAL_RESTD_PORT:-6820}"
ACCT="${SLURM_LOCAL_ACCOUNTING:-0}"
DB_PORT="${SLURM_LOCAL_DB_PORT:-3307}"
DBD_PORT="${SLURM_LOCAL_DBD_PORT:-6819}"
NODE="$(hostname -s)"
CPUS="${SLURM_LOCAL_CPUS:-$(nproc)}"
ME="$(id -un)"

t0=$(date +%s%3N)
log() { local ms=$(( $(date +%s%3N) - t0 )); printf '[slurm-local %d.%03ds] %s\n' $((ms/1000)) $((ms%1000)) "$*" >&2; }
die() { log "ERROR: $*"; exit 1; }

for b in munged mungekey slurmctld slurmd sinfo scontrol; do
  command -v "$b" >/dev/null 2>&1 || [ -x "/usr/sbin/$b" ] || die "missing $b (install slurmctld slurmd slurm-client munge)"
done
export PATH="$PATH:/usr/sbin"

# Refuse to start twice on the same dir (pid file present and process alive).
for p in munged mariadbd slurmdbd slurmctld slurmd slurmrestd; do
  f="$DIR/run/$p.pid"
  if [ -s "$f" ] && kill -0 "$(cat "$f")" 2>/dev/null; then
    die "$p already running (pid $(cat "$f"), $f); run slurm-local-stop.sh first"
  fi
done

# Fresh state each start (this is a CI fixture, not a persistent cluster). Only ever wipe a
# directory this script created (marker file), never an arbitrary non-empty one.
case "$DIR" in /|/tmp|/tmp/|"$HOME"|"") die "refusing SLURM_LOCAL_DIR=$DIR";; esac
if [ -d "$DIR" ] && [ -n "$(ls -A "$DIR" 2>/dev/null)" ] && [ ! -e "$DIR/.slurm-local" ]; then
  die "$DIR exists, is not empty and was not made by slurm-local.sh; choose another SLURM_LOCAL_DIR"
fi
# A daemon left from an earlier start whose pid file is gone would outlive its directory.
if [ -e "$DIR/.slurm-local" ]; then
  SLURM_LOCAL_DIR="$DIR" bash "$(dirname "$0")/slurm-local-stop.sh" || true
fi
rm -rf "$DIR"
mkdir -p "$DIR"/{etc,run,log,munge,ctld,spool,jobs}
: > "$DIR/.slurm-local"
chmod 0755 "$DIR/munge"           # munged: socket dir must not be world-writable, but o+x for non-root clients
chmod 0755 "$DIR" "$DIR/jobs"

# ---- munge -------------------------------------------------------------------------------
mungekey --create --keyfile="$DIR/munge/munge.key" --bits=1024 >/dev/null 2>&1 \
  || dd if=/dev/urandom of="$DIR/munge/munge.key" bs=128 count=1 status=none
chmod 0400 "$DIR/munge/munge.key"
MUNGE_SOCK="$DIR/munge/munge.socket"
munged --key-file="$DIR/munge/munge.key" --socket="$MUNGE_SOCK" \
       --pid-file="$DIR/run/munged.pid" --log-file="$DIR/log/munged.log" \
       --seed-file="$DIR/munge/munged.seed" --force \
  || die "munged failed (see $DIR/log/munged.log)"
for _ in $(seq 50); do [ -S "$MUNGE_SOCK" ] && break; sleep 0.1; done
munge -n --socket="$MUNGE_SOCK" | unmunge --socket="$MUNGE_SOCK" >/dev/null \
  || die "munge round-trip failed"
log "munged up (pid $(cat "$DIR/run/munged.pid"))"

# ---- slurm.conf ---------------------------------------------------------------------------
MEM_MB="${SLURM_LOCAL_MEM_MB:-$(slurmd -C 2>/dev/null | sed -n 's/.*RealMemory=\([0-9]*\).*/\1/p' | head -1)}"
MEM_MB="${MEM_MB:-1024}"
MEM_MB=$(( MEM_MB * 9 / 10 ))
cat > "$DIR/etc/slurm.conf" <<EOF
# generated by slurm-local.sh — single-node test cluster
ClusterName=localci
SlurmctldHost=${NODE}(127.0.0.1)
SlurmctldPort=${CTLD_PORT}
SlurmdPort=${SLURMD_PORT}
SlurmUser=${ME}
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
# cred_expire: a requeued job waits this long (+1 s) before it starts again (default 120 s)
AuthInfo=socket=${MUNGE_SOCK},cred_expire=10
StateSaveLocation=${DIR}/ctld
SlurmdSpoolDir=${DIR}/spool
SlurmctldPidFile=${DIR}/run/slurmctld.pid
SlurmdPidFile=${DIR}/run/slurmd.pid
SlurmctldLogFile=${DIR}/log/slurmctld.log
SlurmdLogFile=${DIR}/log/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
# no cgroups: plain /proc process tracking, no task confinement
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
MpiDefault=none
MailProg=/bin/true
SwitchType=switch/none
# accounting: none (default; sacct disabled) or a private slurmdbd (SLURM_LOCAL_ACCOUNTING=1).
# A plain-text completion log is kept either way (readable with: sacct -c).
$( if [ "$ACCT" = 1 ]; then
     printf 'AccountingStorageType=accounting_storage/slurmdbd\nAccountingStorageHost=127.0.0.1\nAccountingStoragePort=%s\n' "$DBD_PORT"
     # the dbd connection does not use AuthInfo's socket; this names the munge socket for it
     printf 'AccountingStoragePass=%s\n' "$MUNGE_SOCK"
   else
     printf 'AccountingStorageType=accounting_storage/none\n'
   fi )
JobCompType=jobcomp/filetxt
JobCompLoc=${DIR}/log/jobcomp.log
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
# keep finished jobs visible to scontrol/squeue for 10 min; requeue allowed
MinJobAge=600
JobRequeue=1
SchedulerParameters=sched_interval=1,bf_interval=1
SlurmdTimeout=30
SlurmctldTimeout=30
InactiveLimit=0
KillWait=5
$( [ "$RESTD" = tcp ] && printf 'AuthAltTypes=auth/jwt\nAuthAltParameters=jwt_key=%s\n' "$DIR/etc/jwt_hs256.key" )
NodeName=${NODE} NodeAddr=127.0.0.1 NodeHostname=${NODE} CPUs=${CPUS} RealMemory=${MEM_MB} State=UNKNOWN
PartitionName=debug Nodes=${NODE} Default=YES MaxTime=INFINITE State=UP OverSubscribe=NO
EOF
if [ "$RESTD" = tcp ]; then
  dd if=/dev/urandom of="$DIR/etc/jwt_hs256.key" bs=32 count=1 status=none
  chmod 0600 "$DIR/etc/jwt_hs256.key"
fi
export SLURM_CONF="$DIR/etc/slurm.conf"

# ---- optional accounting: private MariaDB + slurmdbd -------------------------------------
if [ "$ACCT" = 1 ]; then
  for b in mariadbd mariadb mariadb-install-db slurmdbd sacctmgr; do
    command -v "$b" >/dev/null 2>&1 || die "SLURM_LOCAL_ACCOUNTING=1 needs $b (apt-get install slurmdbd mariadb-server)"
  done
  mkdir -p "$DIR/mysql" "$DIR/mysqlrun"
  mariadb-install-db --no-defaults --user="$ME" --datadir="$DIR/mysql" \
      --auth-root-authentication-method=socket --skip-test-db >"$DIR/log/mariadb-install.log" 2>&1 \
    || die "mariadb-install-db failed (see $DIR/log/mariadb-install.log)"
  setsid mariadbd --no-defaults --user="$ME" --datadir="$DIR/mysql" --socket="$DIR/mysqlrun/mysqld.sock" \
      --pid-file="$DIR/run/mariadbd.pid" --bind-address=127.0.0.1 --port="$DB_PORT" \
      --log-error="$DIR/log/mariadbd.log" --skip-log-bin --skip-name-resolve \
      --innodb-buffer-pool-size=64M --innodb-lock-wait-timeout=900 >/dev/null 2>&1 </dev/null &
  DBSQL=(mariadb --no-defaults -S "$DIR/mysqlrun/mysqld.sock" -uroot)
  for _ in $(seq 100); do "${DBSQL[@]}" -e 'SELECT 1' >/dev/null 2>&1 && break; sleep 0.1; done
  "${DBSQL[@]}" -e 'SELECT 1' >/dev/null 2>&1 || die "mariadbd not answering (see $DIR/log/mariadbd.log)"
  DBPASS="$(head -c 18 /dev/urandom | base64 | tr -dc 'A-Za-z0-9')"
  "${DBSQL[@]}" -e "CREATE DATABASE slurm_acct_db; CREATE USER 'slurm'@'127.0.0.1' IDENTIFIED BY '$DBPASS'; GRANT ALL ON slurm_acct_db.* TO 'slurm'@'127.0.0.1';" \
    || die "could not create the accounting database"
  log "mariadbd up (pid $(cat "$DIR/run/mariadbd.pid"), 127.0.0.1:$DB_PORT)"
  cat > "$DIR/etc/slurmdbd.conf" <<EOF2
AuthType=auth/munge
AuthInfo=socket=${MUNGE_SOCK}
DbdHost=${NODE}
DbdAddr=127.0.0.1
DbdPort=${DBD_PORT}
SlurmUser=${ME}
PidFile=${DIR}/run/slurmdbd.pid
LogFile=${DIR}/log/slurmdbd.log
StorageType=accounting_storage/mysql
StorageHost=127.0.0.1
StoragePort=${DB_PORT}
StorageUser=slurm
StoragePass=${DBPASS}
StorageLoc=slurm_acct_db
EOF2
  chmod 0600 "$DIR/etc/slurmdbd.conf"
  # slurmdbd reads slurmdbd.conf from the directory of $SLURM_CONF
  slurmdbd || die "slurmdbd failed (see $DIR/log/slurmdbd.log)"
  for _ in $(seq 100); do (exec 3<>"/dev/tcp/127.0.0.1/$DBD_PORT") 2>/dev/null && break; sleep 0.1; done
  (exec 3<>"/dev/tcp/127.0.0.1/$DBD_PORT") 2>/dev/null || die "slurmdbd not listening (see $DIR/log/slurmdbd.log)"
  sacctmgr -i add cluster localci >/dev/null || die "sacctmgr add cluster failed"
  log "slurmdbd up (pid $(cat "$DIR/run/slurmdbd.pid"), 127.0.0.1:$DBD_PORT), cluster registered"
fi

# ---- daemons ------------------------------------------------------------------------------
# -c: start with clean state; both daemonize and write their pid files.
slurmctld -c -f "$SLURM_CONF" || die "slurmctld failed (see $DIR/log/slurmctld.log)"
for _ in $(seq 100); do scontrol ping 2>/dev/null | grep -q 'is UP' && break; sleep 0.1; done
scontrol ping 2>/dev/null | grep -q 'is UP' || die "slurmctld not answering (see $DIR/log/slurmctld.log)"
log "slurmctld up (pid $(cat "$DIR/run/slurmctld.pid"))"

slurmd -f "$SLURM_CONF" -N "$NODE" || die "slurmd failed (see $DIR/log/slurmd.log)"
for _ in $(seq 50); do [ -s "$DIR/run/slurmd.pid" ] && break; sleep 0.1; done
[ -s "$DIR/run/slurmd.pid" ] || die "slurmd wrote no pid file (see $DIR/log/slurmd.log)"
log "slurmd up (pid $(cat "$DIR/run/slurmd.pid"))"

state=""
for _ in $(seq $(( TIMEOUT * 5 ))); do
  state="$(sinfo -h -n "$NODE" -o %T 2>/dev/null | head -1 || true)"
  [ "$state" = "idle" ] && break
  sleep 0.2
done
[ "$state" = "idle" ] || die "node not idle after ${TIMEOUT}s (state='$state'); see $DIR/log/"
log "node $NODE idle — cluster ready"

# ---- optional slurmrestd (does not daemonize: run detached, record $!) -----------------------
if [ "$RESTD" != none ]; then
  command -v slurmrestd >/dev/null || die "SLURM_LOCAL_RESTD=$RESTD but slurmrestd is not installed"
  if [ "$RESTD" = unix ]; then
    # rest_auth/local: the client must have the same uid as slurmrestd; slurmrestd refuses
    # to run as root unless told to skip that check.
    [ "$(id -u)" = 0 ] && export SLURMRESTD_SECURITY=disable_user_check
    setsid slurmrestd -f "$SLURM_CONF" -a rest_auth/local -s openapi/v0.0.38 \
      "unix:$DIR/run/slurmrestd.sock" >"$DIR/log/slurmrestd.log" 2>&1 </dev/null &
    echo $! > "$DIR/run/slurmrestd.pid"
    for _ in $(seq 50); do [ -S "$DIR/run/slurmrestd.sock" ] && break; sleep 0.1; done
    [ -S "$DIR/run/slurmrestd.sock" ] || die "slurmrestd socket missing (see $DIR/log/slurmrestd.log)"
    log "slurmrestd up (pid $(cat "$DIR/run/slurmrestd.pid"), unix:$DIR/run/slurmrestd.sock)"
  elif [ "$RESTD" = tcp ]; then
    # rest_auth/jwt on loopback; drop root after binding (slurmrestd refuses to serve as root).
    # SLURM_JWT=daemon makes slurmrestd talk to slurmctld with the caller's token (auth/jwt)
    # instead of its own munge credential (else: "Rejecting thread config token for user").
    u=(); [ "$(id -u)" = 0 ] && u=(-u nobody)
    SLURM_JWT=daemon setsid slurmrestd -f "$SLURM_CONF" "${u[@]}" -a rest_auth/jwt -s openapi/v0.0.38 \
      "127.0.0.1:$RESTD_PORT" >"$DIR/log/slurmrestd.log" 2>&1 </dev/null &
    echo $! > "$DIR/run/slurmrestd.pid"
    for _ in $(seq 50); do curl -s -o /dev/null "http://127.0.0.1:$RESTD_PORT/" && break; sleep 0.1; done
    kill -0 "$(cat "$DIR/run/slurmrestd.pid")" 2>/dev/null || die "slurmrestd exited (see $DIR/log/slurmrestd.log)"
    log "slurmrestd up (pid $(cat "$DIR/run/slurmrestd.pid"), http://127.0.0.1:$RESTD_PORT, JWT: scontrol token)"
  else
    die "SLURM_LOCAL_RESTD must be none, unix or tcp"
  fi
fi
echo "export SLURM_CONF=$SLURM_CONF"
