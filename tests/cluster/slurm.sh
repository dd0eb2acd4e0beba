#!/usr/bin/env bash
# The reduced campaign (config/tests/ci.yaml) through a real one-node SLURM cluster and the shipped
# profile (profiles/slurm), checked against a local run of the same configuration.
#
# As root on Debian (12): installs munge and Slurm when they are missing and starts a private
# one-node cluster (tests/cluster/cluster.sh), then
#   1. runs the campaign locally (profiles/default) into <work>/local,
#   2. runs it through SLURM with `--workflow-profile profiles/slurm` into <work>/cluster,
#   3. compares every product (tests/cluster/compare_runs.py): byte for byte where a local run
#      is byte-reproducible, trial files by their groups' content digests,
#   4. remakes Table 2 through SLURM from an identification table that is not one, and checks
#      that its job is reported failed and Snakemake exits non-zero within a minute.
# Every daemon it started is stopped by PID on exit, whatever happens (trap), and the Slurm
# configuration it wrote is removed. It prints the seconds of each part.
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
# preconditions, installation, the cluster
# ---------------------------------------------------------------------------------------------
# shellcheck source=tests/cluster/cluster.sh
. "$REPO/tests/cluster/cluster.sh"
T_START=$SECONDS
cluster_install
[ -x "$SNAKEMAKE" ] || fail "$SNAKEMAKE is missing: run 'make test-slurm' (it installs .venv with the cluster extra)"
"$PY" -c "import snakemake_executor_plugin_slurm" 2>/dev/null \
    || fail "the SLURM executor plugin is not in .venv: run 'make test-slurm' (installs '.[test,cluster]' from constraints.txt)"

WORK="${SLURM_TEST_WORK:-$(mktemp -d /tmp/campaign-slurm-test.XXXXXX)}"
mkdir -p "$WORK"
WORK="$(cd "$WORK" && pwd)"
KEEP_WORK="${SLURM_TEST_WORK:+1}"
passed=0
on_exit() {
    local rc=$?
    cluster_stop
    if [ "$passed" = 1 ] && [ -z "$KEEP_WORK" ]; then
        rm -rf "$WORK"
    else
        say "run folders and daemon logs kept in $WORK"
    fi
    exit "$rc"
}
trap on_exit EXIT
trap 'exit 130' INT TERM

say "work folder $WORK"
cluster_start "$WORK/slurm"
SETUP_SECONDS=$((SECONDS - T_START))
say "installed and started in ${SETUP_SECONDS} s"

# ---------------------------------------------------------------------------------------------
# the reduced campaign, locally and through the cluster, each in its own folder
# ---------------------------------------------------------------------------------------------
run_campaign() {  # run_campaign <folder> <log> [snakemake options...]
    local dir="$1" log="$2"
    shift 2
    mkdir -p "$dir"
    timeout --kill-after=20 "$CAMPAIGN_TIMEOUT" "$SNAKEMAKE" -s "$REPO/Snakefile" --directory "$dir" \
        --configfile "$REPO/config/tests/ci.yaml" "$@" > "$log" 2>&1
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
submitted="$(grep -c 'Job [^ ]* has been submitted with SLURM jobid' "$WORK/cluster.log" || true)"
[ "$submitted" -gt 0 ] || fail "the cluster run submitted no SLURM job (log $WORK/cluster.log)"
say "cluster run: $submitted SLURM jobs in ${CLUSTER_SECONDS} s (local ${LOCAL_SECONDS} s)"

say "products, cluster against local"
"$PY" "$REPO/tests/cluster/compare_runs.py" "$WORK/local" "$WORK/cluster" \
    || fail "the cluster run's products differ from the local run's (folders kept in $WORK)"

# ---------------------------------------------------------------------------------------------
# a failing job: Table 2 from an identification table that is not one. Its job (fixed_base,
# which makes the fits and Tables 2-3) must be
# reported failed and Snakemake must exit non-zero within a minute (never wait for ever).
# ---------------------------------------------------------------------------------------------
say "a failing job through SLURM"
bad="$WORK/cluster/results/ci/identify/fixed/high.csv"
printf 'this is not an identification table\n' > "$bad"
t0=$SECONDS
rc=0
timeout --kill-after=10 60 "$SNAKEMAKE" -s "$REPO/Snakefile" --directory "$WORK/cluster" \
    --configfile "$REPO/config/tests/ci.yaml" --workflow-profile "$REPO/profiles/slurm" table2 \
    > "$WORK/failing.log" 2>&1 || rc=$?
FAIL_SECONDS=$((SECONDS - t0))
[ "$rc" != 124 ] && [ "$rc" != 137 ] || fail "Snakemake still waited after 60 s for a failed SLURM job (log $WORK/failing.log)"
[ "$rc" != 0 ] || fail "Snakemake exited 0 although the table2 job failed (log $WORK/failing.log)"
grep -q 'Error in rule fixed_base' "$WORK/failing.log" \
    || fail "the failed job is not reported as failed (exit $rc; log $WORK/failing.log)"
grep -q 'has been submitted with SLURM jobid' "$WORK/failing.log" \
    || fail "the failing job was not submitted to SLURM (log $WORK/failing.log)"
[ ! -e "$WORK/cluster/results/ci/tables/table2.csv" ] \
    || fail "the failed job's output results/ci/tables/table2.csv was left behind"
say "failing job reported failed, Snakemake exited $rc after ${FAIL_SECONDS} s"

passed=1
say "PASSED: cluster set-up ${SETUP_SECONDS} s, campaign local ${LOCAL_SECONDS} s, through SLURM ${CLUSTER_SECONDS} s ($submitted jobs), failing job detected in ${FAIL_SECONDS} s; total $((SECONDS - T_START)) s"
