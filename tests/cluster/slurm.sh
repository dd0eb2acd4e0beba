#!/usr/bin/env bash
# The reduced campaign (config/ci.yaml) through a real one-node SLURM cluster and the shipped
# profile (profiles/slurm), checked against a local run of the same configuration.
#
# As root on Debian (12): installs munge and Slurm from the distribution's packages when they
# are missing, starts munged, slurmctld and slurmd by hand with private state, key and config
# files (nothing under /etc is changed), then
#   1. runs the campaign locally (profiles/default) into <work>/local,
#   2. runs it through SLURM with `--workflow-profile profiles/slurm` into <work>/cluster,
#   3. compares every product (tests/cluster/compare_runs.py): byte for byte where a local run
#      is byte-reproducible, trial files by their groups' content digests,
#   4. submits a workflow whose job fails and checks that Snakemake reports it and exits
#      non-zero within a minute.
# Every daemon it started is stopped by PID on exit, whatever happens (trap).
#
# Usage: tests/cluster/slurm.sh [--skip-if-unable]    (`make test-slurm`)
#   --skip-if-unable   on a machine that cannot run it (not root, no apt-get, packages not
#                      installable) print why in one line and exit 0 instead of 1.
# Environment: SLURM_TEST_WORK=<dir> keeps the run folders there (default: a temporary folder,
# removed on success); SLURM_TEST_TIMEOUT=<s> bounds the cluster campaign (default 600).
set -euo pipefail

REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
PY="$REPO/.venv/bin/python"
SNAKEMAKE="$REPO/.venv/bin/snakemake"
SKIP_IF_UNABLE=0
for arg in "$@"; do
    case "$arg" in
        --skip-if-unable) SKIP_IF_UNABLE=1 ;;
        *) echo "slurm.sh: unknown argument '$arg' (only --skip-if-unable)" >&2; exit 2 ;;
    esac
done
CAMPAIGN_TIMEOUT="${SLURM_TEST_TIMEOUT:-600}"
case "$CAMPAIGN_TIMEOUT" in
    ''|*[!0-9]*) echo "slurm.sh: SLURM_TEST_TIMEOUT='$CAMPAIGN_TIMEOUT' is not a whole number of seconds" >&2; exit 2 ;;
esac

say() { echo "[slurm-test $(date -u +%H:%M:%S)] $*"; }
fail() { echo "slurm-test FAILED: $*" >&2; exit 1; }
unable() {
    if [ "$SKIP_IF_UNABLE" = 1 ]; then
        echo "slurm-test skipped: $1"
        exit 0
    fi
    echo "slurm-test cannot run: $1 (pass --skip-if-unable to skip)" >&2
    exit 1
}

# ---------------------------------------------------------------------------------------------
# preconditions and installation
# ---------------------------------------------------------------------------------------------
[ "$(id -u)" = 0 ] || unable "it must run as root (it installs and starts munge and Slurm)"
[ -x "$SNAKEMAKE" ] || fail "$SNAKEMAKE is missing: run 'make test-slurm' (it installs .venv with the cluster extra)"
"$PY" -c "import snakemake_executor_plugin_slurm" 2>/dev/null \
    || fail "the SLURM executor plugin is not in .venv: run 'make test-slurm' (installs '.[test,cluster]' from constraints.txt)"

T_START=$SECONDS
PACKAGES=(slurmctld slurmd slurm-client munge)
need_install=0
for tool in munged slurmctld slurmd sbatch squeue scontrol; do
    command -v "$tool" >/dev/null || need_install=1
done
if [ "$need_install" = 1 ]; then
    command -v apt-get >/dev/null || unable "Slurm is not installed and there is no apt-get to install it"
    say "installing ${PACKAGES[*]} (apt-get)"
    # policy-rc.d 101: the packages' maintainer scripts must not start the daemons; this script
    # starts its own, with its own configuration, and stops exactly those.
    policy=/usr/sbin/policy-rc.d
    made_policy=0
    if [ ! -e "$policy" ]; then
        printf '#!/bin/sh\nexit 101\n' > "$policy" && chmod 755 "$policy" && made_policy=1
    fi
    apt_ok=1
    { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${PACKAGES[@]}"; } \
        > /tmp/slurm-test-apt.log 2>&1 || apt_ok=0
    [ "$made_policy" = 1 ] && rm -f "$policy"
    [ "$apt_ok" = 1 ] || unable "apt-get could not install ${PACKAGES[*]} (see /tmp/slurm-test-apt.log)"
fi
for tool in munged slurmctld slurmd sbatch squeue scontrol; do
    command -v "$tool" >/dev/null || fail "$tool is still missing after installing ${PACKAGES[*]}"
done

# ---------------------------------------------------------------------------------------------
# a private one-node cluster: key, config, state and logs in $STATE, daemons in the foreground
# (-F / -D) as children of this script so that their PIDs are known and they are stopped here
# ---------------------------------------------------------------------------------------------
WORK="${SLURM_TEST_WORK:-$(mktemp -d /tmp/campaign-slurm-test.XXXXXX)}"
mkdir -p "$WORK"
WORK="$(cd "$WORK" && pwd)"
STATE="$WORK/slurm"
rm -rf "$STATE"
mkdir -p "$STATE"/{munge,spool/ctld,spool/d}
chmod 700 "$STATE/munge"
DAEMON_PIDS=()
WROTE_CONF=0
KEEP_WORK="${SLURM_TEST_WORK:+1}"
passed=0

stop_daemons() {
    local pid jobs
    # jobs still queued or running (a run stopped by its timeout) end with the cluster: their
    # slurmstepd would otherwise outlive slurmd
    if [ "${#DAEMON_PIDS[@]}" -gt 0 ] && jobs="$(squeue -h -o %i 2>/dev/null)" && [ -n "$jobs" ]; then
        scancel $jobs 2>/dev/null || true
        for _ in $(seq 50); do [ -z "$(squeue -h -o %i 2>/dev/null)" ] && break; sleep 0.2; done
    fi
    # slurmd first (it may still report to slurmctld), munged last (both authenticate with it)
    for ((i = ${#DAEMON_PIDS[@]} - 1; i >= 0; i--)); do
        pid="${DAEMON_PIDS[i]}"
        kill -TERM "$pid" 2>/dev/null || true
    done
    for pid in "${DAEMON_PIDS[@]}"; do
        for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
        if kill -0 "$pid" 2>/dev/null; then kill -KILL "$pid" 2>/dev/null || true; fi
        wait "$pid" 2>/dev/null || true
    done
    [ "${#DAEMON_PIDS[@]}" = 0 ] || say "stopped daemons (PIDs ${DAEMON_PIDS[*]})"
    DAEMON_PIDS=()
}
on_exit() {
    local rc=$?
    stop_daemons
    if [ "$WROTE_CONF" = 1 ]; then rm -f "$SLURM_CONF" "$SLURM_CONF.tmp"; fi
    if [ "$passed" = 1 ] && [ -z "$KEEP_WORK" ]; then
        rm -rf "$WORK"
    else
        say "run folders and daemon logs kept in $WORK"
    fi
    exit "$rc"
}
trap on_exit EXIT
trap 'exit 130' INT TERM

start_daemon() {  # start_daemon <name> <command...>: run in the background, remember the PID
    local name="$1"
    shift
    "$@" > "$STATE/$name.out" 2>&1 &
    DAEMON_PIDS+=("$!")
}

say "work folder $WORK"
dd if=/dev/urandom of="$STATE/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$STATE/munge/munge.key"
MUNGE_SOCKET="$STATE/munge/munge.socket"
start_daemon munged munged --foreground --force \
    --key-file="$STATE/munge/munge.key" --socket="$MUNGE_SOCKET" \
    --pid-file="$STATE/munge/munged.pid" --log-file="$STATE/munge/munged.log" \
    --seed-file="$STATE/munge/munged.seed"
for _ in $(seq 50); do [ -S "$MUNGE_SOCKET" ] && break; sleep 0.1; done
[ -S "$MUNGE_SOCKET" ] || fail "munged did not start: $(tail -3 "$STATE/munged.out" "$STATE/munge/munged.log" 2>/dev/null)"

NODE="$(hostname -s)"
# the node's hardware line as slurmd sees it (CPUs, sockets, cores, threads, RealMemory)
NODE_LINE="$(slurmd -C | head -1)"
case "$NODE_LINE" in NodeName=*) ;; *) fail "slurmd -C printed no node line: $NODE_LINE" ;; esac
# The configuration goes where every Slurm command looks by default: the SLURM plugin's job
# step removes SLURM_* variables (SLURM_CONF too) before its srun. A configuration this script
# did not write is never replaced (the machine then belongs to another cluster).
SLURM_CONF=/etc/slurm/slurm.conf
MARK="# one-node test cluster of tests/cluster/slurm.sh"
if [ -e "$SLURM_CONF" ] && ! head -1 "$SLURM_CONF" | grep -qxF "$MARK"; then
    unable "$SLURM_CONF exists and was not written by this script (the machine has its own Slurm)"
fi
mkdir -p "$(dirname "$SLURM_CONF")"
WROTE_CONF=1
cat > "$SLURM_CONF.tmp" <<EOF
$MARK
# (state in $STATE); no accounting (no slurmdbd), as on a
# cluster where sacct cannot answer: the profile must track jobs with squeue
ClusterName=campaign-test
SlurmctldHost=$NODE(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$MUNGE_SOCKET
SlurmctldPort=${SLURM_TEST_PORT:-6917}
SlurmdPort=$(( ${SLURM_TEST_PORT:-6917} + 1 ))
StateSaveLocation=$STATE/spool/ctld
SlurmdSpoolDir=$STATE/spool/d
SlurmctldPidFile=$STATE/slurmctld.pid
SlurmdPidFile=$STATE/slurmd.pid
SlurmctldLogFile=$STATE/slurmctld.log
SlurmdLogFile=$STATE/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MinJobAge=300
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
$NODE_LINE NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=debug Nodes=$NODE Default=YES MaxTime=INFINITE State=UP
EOF
mv "$SLURM_CONF.tmp" "$SLURM_CONF"

start_daemon slurmctld slurmctld -D -i -f "$SLURM_CONF"
start_daemon slurmd slurmd -D -f "$SLURM_CONF"
up=0
for _ in $(seq 100); do
    if sinfo -h -o '%T' 2>/dev/null | grep -qx idle; then up=1; break; fi
    sleep 0.2
done
[ "$up" = 1 ] || fail "the node did not come up idle: $(sinfo 2>&1 | tail -2); $(tail -3 "$STATE/slurmctld.log" "$STATE/slurmd.log" 2>/dev/null)"
# the cluster answers a job before the campaign relies on it
probe="$(srun -N1 -n1 -t 1 echo slurm-probe-ok 2>&1)" || fail "srun failed: $probe"
[ "$probe" = slurm-probe-ok ] || fail "srun printed '$probe'"
SETUP_SECONDS=$((SECONDS - T_START))
say "cluster up in ${SETUP_SECONDS} s: $(sinfo -h -o '%P %D %c CPUs %T')"

# ---------------------------------------------------------------------------------------------
# the reduced campaign, locally and through the cluster, each in its own folder
# ---------------------------------------------------------------------------------------------
run_campaign() {  # run_campaign <folder> <log> [snakemake options...]
    local dir="$1" log="$2"
    shift 2
    mkdir -p "$dir"
    timeout --kill-after=20 "$CAMPAIGN_TIMEOUT" "$SNAKEMAKE" -s "$REPO/Snakefile" --directory "$dir" \
        --configfile "$REPO/config/ci.yaml" "$@" > "$log" 2>&1
}

say "reduced campaign, local (profiles/default)"
t0=$SECONDS
run_campaign "$WORK/local" "$WORK/local.log" \
    || fail "the local run failed ($?): $(tail -20 "$WORK/local.log")"
LOCAL_SECONDS=$((SECONDS - t0))

say "reduced campaign through SLURM (--workflow-profile profiles/slurm)"
t0=$SECONDS
rc=0
run_campaign "$WORK/cluster" "$WORK/cluster.log" --workflow-profile "$REPO/profiles/slurm" || rc=$?
CLUSTER_SECONDS=$((SECONDS - t0))
[ "$rc" != 124 ] && [ "$rc" != 137 ] || fail "the cluster run did not finish within ${CAMPAIGN_TIMEOUT} s (log $WORK/cluster.log)"
[ "$rc" = 0 ] || fail "the cluster run failed ($rc): $(tail -30 "$WORK/cluster.log")"
submitted="$(grep -c 'Job [0-9]* has been submitted with SLURM jobid' "$WORK/cluster.log" || true)"
[ "$submitted" -gt 0 ] || fail "the cluster run submitted no SLURM job (log $WORK/cluster.log)"
say "cluster run: $submitted SLURM jobs in ${CLUSTER_SECONDS} s (local ${LOCAL_SECONDS} s)"

say "products, cluster against local"
"$PY" "$REPO/tests/cluster/compare_runs.py" "$WORK/local" "$WORK/cluster" \
    || fail "the cluster run's products differ from the local run's (folders kept in $WORK)"

# ---------------------------------------------------------------------------------------------
# a failing job: Table 2 from an identification table that is not one. Its job must be
# reported failed and Snakemake must exit non-zero within a minute (never wait for ever).
# ---------------------------------------------------------------------------------------------
say "a failing job through SLURM"
bad="$WORK/cluster/results/ci/identify/fixed/high.csv"
printf 'this is not an identification table\n' > "$bad"
t0=$SECONDS
rc=0
timeout --kill-after=10 60 "$SNAKEMAKE" -s "$REPO/Snakefile" --directory "$WORK/cluster" \
    --configfile "$REPO/config/ci.yaml" --workflow-profile "$REPO/profiles/slurm" table2 \
    > "$WORK/failing.log" 2>&1 || rc=$?
FAIL_SECONDS=$((SECONDS - t0))
[ "$rc" != 124 ] && [ "$rc" != 137 ] || fail "Snakemake still waited after 60 s for a failed SLURM job (log $WORK/failing.log)"
[ "$rc" != 0 ] || fail "Snakemake exited 0 although the table2 job failed (log $WORK/failing.log)"
grep -q 'Error in rule table2_effective_mass' "$WORK/failing.log" \
    || fail "the failed job is not reported as failed (exit $rc; log $WORK/failing.log)"
grep -q 'has been submitted with SLURM jobid' "$WORK/failing.log" \
    || fail "the failing job was not submitted to SLURM (log $WORK/failing.log)"
[ ! -e "$WORK/cluster/results/ci/tables/table2.csv" ] \
    || fail "the failed job's output results/ci/tables/table2.csv was left behind"
say "failing job reported failed, Snakemake exited $rc after ${FAIL_SECONDS} s"

passed=1
say "PASSED: cluster set-up ${SETUP_SECONDS} s, campaign local ${LOCAL_SECONDS} s, through SLURM ${CLUSTER_SECONDS} s ($submitted jobs), failing job detected in ${FAIL_SECONDS} s; total $((SECONDS - T_START)) s"
