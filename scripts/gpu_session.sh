#!/usr/bin/env bash
# Every GPU measurement of issues 36 and 37 in one run, for a lent GPU machine (the device
# tool gives about 15 minutes a session: one prepared run, not many small calls).
#
#   scripts/gpu_session.sh OUTDIR            # on the lent machine, from the checkout
#   STEPS="env bench fig14" scripts/gpu_session.sh OUTDIR   # only these steps (by first word)
#   SMOKE=1 NUMBA_ENABLE_CUDASIM=1 scripts/gpu_session.sh /tmp/s   # here: the script runs
#
# The lent machine lacks dask, pydantic, h5netcdf and a few more (../shared/recipes/gpu.md):
# carried as cp312 wheels in .whl/ they are installed into /tmp/site first. ../shared/anchors
# (the hand kernel) is carried in .devshared/anchors. Each step has its own time limit and
# its own log in OUTDIR, so one that fails or hangs costs only its own limit; the steps run
# in the order of what matters most. Steps: env, fig14 (end to end on the GPU), variants
# (gpu_check --run), bench (bench_gpu), efficiency (bench_efficiency, all cores), map,
# plan (the GPU-calibrated estimate), workers (a dask worker with a GPU resource).
set -u
OUT=${1:?usage: gpu_session.sh OUTDIR}
mkdir -p "$OUT"
export PYTHONUNBUFFERED=1
if [ -d .whl ] && ls .whl/*.whl >/dev/null 2>&1; then
    # (byte-compiled here once, not by each of 16 workers importing dask at the same time)
    python3 -m pip install -q --no-index --no-deps --no-cache-dir --upgrade \
        --target /tmp/site .whl/*.whl && export PYTHONPATH=/tmp/site
fi
export PYTHONPATH=$PWD${PYTHONPATH:+:$PYTHONPATH}
if [ ! -d ../shared/anchors ] && [ -d .devshared/anchors ]; then
    mkdir -p ../shared && cp -r .devshared/anchors ../shared/
fi
PY=${PYTHON:-python3}
STORE=$(mktemp -d)

step() {   # step NAME LIMIT_S COMMAND...: runs it bounded, logs it, says its time and exit
    local name=$1 limit=$2 t0=$SECONDS rc
    shift 2
    case " ${STEPS:-${name%%_*}} " in *" ${name%%_*} "*) ;; *) return ;; esac
    echo "=== $name (limit ${limit} s) at $(date +%T)"
    timeout "$limit" "$@" >"$OUT/$name.log" 2>&1
    rc=$?
    tail -n 40 "$OUT/$name.log"
    echo "=== $name: $((SECONDS - t0)) s, exit $rc"
}

if [ -n "${SMOKE:-}" ]; then
    BENCH=(--smoke) MAP=3 EFF=(--sweeps cheap --workers 2) CASES=(lugre-square-rk4)
else
    BENCH=(--points 1048576 --cpu-points 4096 --fig14 65536 --fig14-cpu 256 --fig14-tend 10
           --tpb 64,256 --probe --repeats 2)
    MAP=1000 EFF=(--sweeps cheap,fig14 --workers "$(nproc)") CASES=()
fi
[ -n "${BENCH_ARGS:-}" ] && read -r -a BENCH <<<"$BENCH_ARGS"
[ -n "${EFF_ARGS:-}" ] && read -r -a EFF <<<"$EFF_ARGS"
FIG14_RUNS=${FIG14_RUNS:-2}

step env 30 bash -c "nvidia-smi -L; lscpu | grep -m1 'Model name'; nproc; $PY -c '
import sys, numba, numpy, dask, xarray, pydantic
print(sys.version.split()[0], \"numba\", numba.__version__, \"numpy\", numpy.__version__,
      \"dask\", dask.__version__, \"xarray\", xarray.__version__)
from engine import gpu; print(\"device:\", gpu.check_device())'"

# specs/fig14.toml end to end on the GPU, twice (the first compiles the kernel)
for k in $(seq "$FIG14_RUNS"); do
    step "fig14_cuda_$k" "${FIG14_LIMIT:-45}" $PY -m sweeps.cli submit specs/fig14.toml --device cuda \
        --store "$STORE/fig14-$k" -v
done

step variants 75 $PY scripts/gpu_check.py --run --jobs "$(nproc)" "${CASES[@]}"

step bench_gpu "${BENCH_LIMIT:-200}" $PY scripts/bench_gpu.py "${BENCH[@]}"

# issue 37: efficiency and the fixed costs around a sweep on all of this machine's cores
step efficiency "${EFF_LIMIT:-110}" $PY scripts/bench_efficiency.py "${EFF[@]}"

# a MAP x MAP Fig. 14 map on the GPU (1,000 x 1,000: the issue's 2-minute target)
$PY - "$MAP" "$STORE/map.toml" <<'EOF'
import sys
from pathlib import Path
n, dest = int(sys.argv[1]), Path(sys.argv[2])
text = Path("specs/fig14.toml").read_text().replace('name = "fig14"', f'name = "fig14-{n}"')
text = text.replace("num = 31 }", f"num = {n} }}").replace("num = 31, scale", f"num = {n}, scale")
dest.write_text(text)
EOF
step "map_${MAP}" "${MAP_LIMIT:-150}" $PY -m sweeps.cli submit "$STORE/map.toml" --device cuda \
    --store "$STORE/map" --max-points 2000000 -v

# the GPU-calibrated estimate (ditherlab plan --device cuda), to set beside fig14's launch
SPEC=specs/fig14.toml
if [ -n "${SMOKE:-}" ]; then
    SPEC=$STORE/tiny.toml
    printf '%s\n' 'name = "tiny"' 'friction = "lugre"' 'dither = "square-velocity"' \
        'accuracy = "draft"' '[time]' 't_end = 0.5' 't_transient = 0.1' '[grid]' \
        'W = [0.0, 0.3]' 'omega = [200.0]' 'v_ref = [0.4]' 'v_d = [0.1]' >"$SPEC"
fi
step plan 120 $PY -m sweeps.cli plan "$SPEC" --device cuda

# a dask cluster's GPU worker (dask worker --resources GPU=1) computing the sweep
workers_run() {
    local dir=$STORE/cluster pids=() rc
    mkdir -p "$dir"
    $PY -m distributed.cli.dask_scheduler --host 127.0.0.1 --port 0 --no-dashboard \
        --scheduler-file "$dir/s.json" >"$dir/scheduler.log" 2>&1 &
    pids+=($!)
    for _ in $(seq 100); do [ -s "$dir/s.json" ] && break; sleep 0.2; done
    $PY -m distributed.cli.dask_worker --scheduler-file "$dir/s.json" --nthreads 1 \
        --resources GPU=1 --no-dashboard >"$dir/worker.log" 2>&1 &
    pids+=($!)
    local address
    address=$($PY -c "import json,sys; print(json.load(open(sys.argv[1]))['address'])" \
        "$dir/s.json")
    $PY -m sweeps.cli submit "$SPEC" --device cuda --scheduler "$address" \
        --store "$dir/store" -v
    rc=$?
    kill "${pids[@]}" 2>/dev/null
    return $rc
}
export -f workers_run
export PY STORE SPEC
step workers 150 bash -c workers_run

rm -rf "$STORE"
