# Shell functions that install, start and stop a private one-node SLURM cluster, sourced by
# tests/cluster/slurm.sh (the cluster test) and benchmarks/bench_slurm.sh (its wall times).
#
# As root on Debian (12): munge and Slurm come from the distribution's packages when missing
# (apt-get; the packages' own services are not started). munged, slurmctld and slurmd run in
# the foreground as children of the calling script, with the key, state and logs in
# $STATE, so that their PIDs are known: cluster_stop stops exactly those. The configuration
# goes to /etc/slurm/slurm.conf, where every Slurm command looks by default (the SLURM
# plugin's job step removes SLURM_* variables, SLURM_CONF too, before its srun); one this
# code did not write is never replaced, and the one it wrote is removed by cluster_stop.
#
# The caller defines say <text>, fail <text> (exit 1) and unable <text> (the machine cannot
# run it) and calls cluster_install, then cluster_start <state folder>, and cluster_stop in
# its EXIT trap.

PACKAGES=(slurmctld slurmd slurm-client munge)
SLURM_TOOLS=(munged slurmctld slurmd sbatch squeue scontrol srun)
SLURM_CONF=/etc/slurm/slurm.conf
CONF_MARK="# one-node test cluster of tests/cluster/cluster.sh"
DAEMON_PIDS=()
WROTE_CONF=0

cluster_install() {  # installs munge and Slurm where a tool is missing
    local tool need_install=0 policy=/usr/sbin/policy-rc.d made_policy=0 apt_ok=1
    [ "$(id -u)" = 0 ] || unable "it must run as root (it installs and starts munge and Slurm)"
    for tool in "${SLURM_TOOLS[@]}"; do
        command -v "$tool" >/dev/null || need_install=1
    done
    if [ "$need_install" = 1 ]; then
        command -v apt-get >/dev/null || unable "Slurm is not installed and there is no apt-get to install it"
        say "installing ${PACKAGES[*]} (apt-get)"
        # policy-rc.d 101: the packages' maintainer scripts must not start the daemons; the
        # cluster's own are started below, with their own configuration
        if [ ! -e "$policy" ]; then
            printf '#!/bin/sh\nexit 101\n' > "$policy" && chmod 755 "$policy" && made_policy=1
        fi
        { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${PACKAGES[@]}"; } \
            > /tmp/slurm-test-apt.log 2>&1 || apt_ok=0
        if [ "$made_policy" = 1 ]; then rm -f "$policy"; fi
        [ "$apt_ok" = 1 ] || unable "apt-get could not install ${PACKAGES[*]} (see /tmp/slurm-test-apt.log)"
    fi
    for tool in "${SLURM_TOOLS[@]}"; do
        command -v "$tool" >/dev/null || fail "$tool is still missing after installing ${PACKAGES[*]}"
    done
}

start_daemon() {  # start_daemon <name> <command...>: run in the background, remember the PID
    local name="$1"
    shift
    "$@" > "$STATE/$name.out" 2>&1 &
    DAEMON_PIDS+=("$!")
}

cluster_start() {  # cluster_start <state folder>: key, config, daemons; returns once a job ran
    STATE="$1"
    rm -rf "$STATE"
    mkdir -p "$STATE"/{munge,spool/ctld,spool/d}
    chmod 700 "$STATE/munge"
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
    # a configuration this code did not write belongs to another cluster: never replaced
    if [ -e "$SLURM_CONF" ] && ! head -1 "$SLURM_CONF" | grep -qxF "$CONF_MARK"; then
        unable "$SLURM_CONF exists and was not written by tests/cluster/cluster.sh (the machine has its own Slurm)"
    fi
    mkdir -p "$(dirname "$SLURM_CONF")"
    WROTE_CONF=1
    cat > "$SLURM_CONF.tmp" <<EOF
$CONF_MARK
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
    local up=0 probe
    for _ in $(seq 100); do
        if sinfo -h -o '%T' 2>/dev/null | grep -qx idle; then up=1; break; fi
        sleep 0.2
    done
    [ "$up" = 1 ] || fail "the node did not come up idle: $(sinfo 2>&1 | tail -2); $(tail -3 "$STATE/slurmctld.log" "$STATE/slurmd.log" 2>/dev/null)"
    # the cluster answers a job before the campaign relies on it
    probe="$(srun -N1 -n1 -t 1 echo slurm-probe-ok 2>&1)" || fail "srun failed: $probe"
    [ "$probe" = slurm-probe-ok ] || fail "srun printed '$probe'"
    say "cluster up: $(sinfo -h -o '%P %D %c CPUs %T')"
}

cluster_stop() {  # cancels the cluster's jobs, stops its daemons by PID, removes its config
    local pid jobs i
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
    if [ "$WROTE_CONF" = 1 ]; then rm -f "$SLURM_CONF" "$SLURM_CONF.tmp"; WROTE_CONF=0; fi
}
