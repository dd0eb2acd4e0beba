#!/usr/bin/env bash
# Wall time of the reduced campaign (config/tests/ci.yaml) on a one-node SLURM cluster, by cluster
# profile: profiles/slurm as shipped (the small downstream jobs grouped into one SLURM job)
# against the same profile without its groups (one SLURM job per rule job). Each run starts
# from empty folders; the variants alternate so that a change in the machine's load hits both.
#
# As root on Debian; installs and starts the cluster like `make test-slurm`
# (tests/cluster/cluster.sh) and stops it on exit. Not part of `make bench` (needs root).
#
# Usage: benchmarks/bench_slurm.sh [repeats]     (default 2; prints a Markdown table)
# Record: paste the table into docs/benchmarks.rst (Cluster profile) and docs/cluster.rst.
set -euo pipefail

REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
PY="$REPO/.venv/bin/python"
SNAKEMAKE="$REPO/.venv/bin/snakemake"
REPEATS="${1:-2}"
case "$REPEATS" in ''|*[!0-9]*|0) echo "bench_slurm.sh: repeats '$REPEATS' is not a positive whole number" >&2; exit 2 ;; esac

say() { echo "[bench-slurm $(date -u +%H:%M:%S)] $*" >&2; }
fail() { echo "bench-slurm FAILED: $*" >&2; exit 1; }
unable() { echo "bench-slurm cannot run: $1" >&2; exit 1; }

# shellcheck source=tests/cluster/cluster.sh
. "$REPO/tests/cluster/cluster.sh"
"$PY" -c "import snakemake_executor_plugin_slurm" 2>/dev/null || fail "no SLURM plugin in .venv: run 'make install-cluster'"
WORK="$(mktemp -d /tmp/campaign-slurm-bench.XXXXXX)"
trap 'cluster_stop; rm -rf "$WORK"' EXIT
trap 'exit 130' INT TERM
cluster_install
cluster_start "$WORK/slurm"

# the shipped profile without its grouping keys
mkdir -p "$WORK/ungrouped"
"$PY" - "$REPO/profiles/slurm/config.yaml" "$WORK/ungrouped/config.yaml" <<'EOF'
import sys, yaml
cfg = yaml.safe_load(open(sys.argv[1]))
for key in ("groups", "group-components"):
    cfg.pop(key)
yaml.safe_dump(cfg, open(sys.argv[2], "w"), sort_keys=False)
EOF

declare -A PROFILE=([grouped]="$REPO/profiles/slurm" [ungrouped]="$WORK/ungrouped")
declare -A TIMES JOBS
for rep in $(seq "$REPEATS"); do
    for variant in ungrouped grouped; do
        dir="$WORK/run-$variant-$rep"
        mkdir -p "$dir"
        t0=$(date +%s.%N)
        timeout --kill-after=20 900 "$SNAKEMAKE" -s "$REPO/Snakefile" --directory "$dir" \
            --configfile "$REPO/config/tests/ci.yaml" --workflow-profile "${PROFILE[$variant]}" > "$dir.log" 2>&1 \
            || fail "$variant run $rep failed: $(tail -20 "$dir.log")"
        seconds=$(awk -v a="$t0" -v b="$(date +%s.%N)" 'BEGIN {printf "%.1f", b - a}')
        jobs=$(grep -c 'has been submitted with SLURM jobid' "$dir.log")
        say "$variant run $rep: $seconds s, $jobs SLURM jobs"
        TIMES[$variant]+="$seconds "
        JOBS[$variant]=$jobs
        rm -rf "$dir"
    done
done

median() { printf '%s\n' $1 | sort -g | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2}'; }
echo "| profile | SLURM jobs | runs | median wall [s] | all runs [s] |"
echo "|---|---|---|---|---|"
for variant in ungrouped grouped; do
    all=$(printf '%.0f ' ${TIMES[$variant]})
    printf '| %s | %s | %s | %.0f | %s|\n' "$variant" "${JOBS[$variant]}" "$REPEATS" "$(median "${TIMES[$variant]}")" "$all"
done
echo
echo "Machine: $(nproc) CPUs, $(uname -m); Slurm $(sinfo -V | cut -d' ' -f2), snakemake $("$SNAKEMAKE" --version), plugin $("$PY" -c 'import importlib.metadata as m; print(m.version("snakemake-executor-plugin-slurm"))'); load average at end $(cut -d' ' -f1-3 /proc/loadavg); $(date -u +%Y-%m-%d)."
