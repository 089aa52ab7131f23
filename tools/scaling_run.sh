#!/usr/bin/env bash
# Strong scaling of the thesis-size balance study on a machine with many cores, in one call that
# keeps to a deadline (a developer tool, not shipped with the package).
#
# Usage, from the root of a checkout on that machine:
#
#   tools/scaling_run.sh WHEELS OUT [SECONDS]
#
# WHEELS  a folder of wheels for that machine's Python, installed into a scratch folder (never
#         into the machine's own Python, and without the network): psmat's own, built with that
#         Python version (python3.X -m pip wheel --no-deps -w WHEELS .), and whichever of its
#         dependencies the machine lacks (pip download --only-binary :all: --python-version 3.X
#         --platform manylinux2014_x86_64 --no-deps -d WHEELS NAME==VERSION). "-" uses the psmat
#         that python3 already imports.
# OUT     where the machine's description, the benchmark's printed tables and JSON go.
# SECONDS the deadline for everything (default 560). The steps run in order of importance, each
#         with the time left; one cut by the deadline leaves what it printed in OUT:
#           1. python -m psmat.bench study --scaling $COUNTS: the load probe (one session run by
#              n processes at once), then a process pool at each count;
#           2. the same counts on a Dask LocalCluster (--dask-only), on the same simulated study,
#              or only the largest when the time left would not hold them all (judged from the
#              pool's times); then its metrics.csv is compared byte for byte with the pool's.
#
# Environment: COUNTS (default 2,16), BENCH_ARGS (more arguments for both steps, e.g. --quick to
# try the tool on a tiny study), STUDY_DIR (default /tmp/psmat-scaling-study; kept between steps).
set -u
if [ $# -lt 2 ]; then
  echo "usage: tools/scaling_run.sh WHEELS OUT [SECONDS]" >&2
  exit 2
fi
wheels=$1
out=$2
deadline=$(( $(date +%s) + ${3:-560} ))
counts=${COUNTS:-2,16}
study=${STUDY_DIR:-/tmp/psmat-scaling-study}
mkdir -p "$out" || exit 2

if [ "$wheels" != "-" ]; then
  site=$(mktemp -d /tmp/psmat-site.XXXXXX)
  if ! python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target "$site" "$wheels"/*.whl \
      > "$out/install.txt" 2>&1; then
    echo "the wheels in $wheels did not install (see $out/install.txt)" >&2
    exit 1
  fi
  export PYTHONPATH="$site${PYTHONPATH:+:$PYTHONPATH}"
fi

{
  date -u +%FT%TZ
  nproc
  lscpu 2>/dev/null | grep -E '^(Model name|CPU family|Model|Thread|Core|Socket|NUMA node\(s\)|CPU\(s\)|Flags)' \
    | sed 's/^Flags:.*\(avx512f\).*/Flags: avx512f .../'
  python3 -c 'import psmat, numpy, sys; print(sys.version.split()[0], "psmat", psmat.__version__, psmat.__file__, "numpy", numpy.__version__)'
} > "$out/machine.txt" 2>&1

step() {  # step NAME ARGS...: the benchmark with the time left, its output in OUT/NAME.txt
  local name=$1
  shift
  local left=$(( deadline - $(date +%s) ))
  if [ "$left" -lt 30 ]; then
    echo "$name: not run, $left s left before the deadline" | tee -a "$out/skipped.txt"
    return
  fi
  # ${BENCH_ARGS} unquoted on purpose: several arguments
  # shellcheck disable=SC2086
  timeout --signal=INT --kill-after=10 "$left" python3 -m psmat.bench study --scaling "$counts" --dir "$study" \
    --json "$out/$name.json" ${BENCH_ARGS:-} "$@" > "$out/$name.txt" 2> "$out/$name.err"
  echo "$name: exit status $? after $(( $(date +%s) - deadline + left )) s" | tee -a "$out/steps.txt"
}

step pool
cp "$study/results/metrics.csv" "$out/pool_metrics.csv" 2>/dev/null

# The Dask step gets every count only when the time left holds them at 1.25 times the pool's
# times (and 40 s for the clusters); else the largest count alone, compared with the pool's smallest.
dask_counts=$(python3 - "$out/pool.json" "$(( deadline - $(date +%s) ))" <<'PY'
import json, sys
try:
    runs = {r["workers"]: r["wall_s"] for r in json.load(open(sys.argv[1]))["scaling"]["runs"]
            if r["kind"] == "pool"}
except (OSError, KeyError, ValueError):
    runs = {}
left = float(sys.argv[2])
if runs and left > 1.25 * sum(runs.values()) + 40:
    print(",".join(str(n) for n in sorted(runs)))
elif runs and left > 1.5 * runs[max(runs)] + 30:
    print(max(runs))
PY
)
if [ -n "$dask_counts" ]; then
  counts=$dask_counts
  step dask --dask-only --no-load-probe
  if cmp -s "$out/pool_metrics.csv" "$study/results/metrics.csv"; then
    echo "metrics.csv: the pool's last run and the Dask LocalCluster's last run are byte-identical" \
      | tee -a "$out/steps.txt"
  else
    echo "metrics.csv: the pool's last run and the Dask LocalCluster's last run DIFFER" | tee -a "$out/steps.txt"
  fi
else
  echo "dask: not run, too little time left after the pool's runs" | tee -a "$out/skipped.txt"
fi
