#!/usr/bin/env bash
# The GPU machine's check, in two halves (../shared/notes/gpu-device.md):
#
#   scripts/gpu-device-check.sh prepare         here: the Vulkan loader packages and the binaries
#                                               that travel, all in .gl/ (ignored by git)
#   scripts/gpu-device-check.sh run [--software] there, in one `run` call of the device tool:
#       carry [".gl"], timeout_s 360. Its 20 steps' limits add up to 235 s; each is killed 2 s
#       after its limit at worst (the paper job 10 s): 283 s, and the loader's setup and
#       `nvidia-smi -L` before them are bounded by 15 s: 298 s, so a second call still fits in
#       the session's 15 minutes. (--software doubles every limit: lavapipe is a CPU.)
#
# `run --software` goes end to end on lavapipe here (and in CI) with smaller sizes, so the GPU
# machine never meets this script for the first time. Everything lands in $OUT:
#   steps.tsv    each step: name, exit code, time taken, start (UTC, to line up with smi.csv);
#                a step's failure does not stop the next
#   info.txt     adapters (sweep info), nvidia-smi, the loader's diagnostics when no GPU is found
#   tests.txt    the GPU tests of the suite on the adapter
#   bench.jsonl  one JSON line per bench, a "run" name added; smi.csv: utilisation beside them
#   paper.txt    one paper-scale silo job for a bounded time, then `sweep plan --backend gpu`
# Exit: 0 when every step passed, 3 when no usable adapter was found, else 1.
set -uo pipefail
cd "$(dirname "$0")/.."
GL=.gl

prepare() {
    set -e
    mkdir -p "$GL/bin" /tmp/amd64/partial
    if ! ls "$GL"/libvulkan1_*.deb >/dev/null 2>&1; then
        local o='-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64'
        # shellcheck disable=SC2086
        apt-get $o update -qq
        # shellcheck disable=SC2086
        (cd "$GL" && apt-get $o download libvulkan1)
    fi
    # Both binaries from the test build (the one CI has just made): a plain `cargo build`
    # resolves the dependencies' features without the dev-dependencies and compiles them all
    # again (4 minutes on 2 cores).
    local bins sweep suite
    bins=$(cargo test --release --no-run --message-format=json 2>/tmp/gpu-prepare-cargo.txt |
        python3 -c 'import json,sys
for l in sys.stdin:
    m = json.loads(l)
    if m.get("reason") != "compiler-artifact" or not m.get("executable"):
        continue
    t = m["target"]
    if t["name"] == "sweep" and t["kind"] == ["bin"] and not m["profile"]["test"]:
        print("sweep", m["executable"])
    elif t["name"] == "suite" and t["kind"] == ["test"]:
        print("suite", m["executable"])')
    sweep=$(awk '$1 == "sweep" {print $2}' <<< "$bins")
    suite=$(awk '$1 == "suite" {print $2}' <<< "$bins")
    if [ -z "$sweep" ] || [ -z "$suite" ]; then
        tail -30 /tmp/gpu-prepare-cargo.txt >&2
        echo "prepare: the test build gave no sweep or suite binary (cargo's output above)" >&2
        exit 1
    fi
    install -m 755 "$sweep" "$GL/bin/sweep"
    install -m 755 "$suite" "$GL/bin/suite"
    strip "$GL/bin/sweep" "$GL/bin/suite" 2>/dev/null || true
    du -sh "$GL"
    echo "prepared: run \`scripts/gpu-device-check.sh run\` there with carry [\".gl\"]"
}

OUT=${OUT:-/tmp/gpu-out}
STEPS=$OUT/steps.tsv
FAILED=0

# step NAME LIMIT_S CMD...: runs CMD under a time limit, records its exit code and time.
# STEP_OK (default 0) lists the exit codes that count as passed. STEP_FG=1 signals CMD alone,
# once, and keeps its exit code (sweep takes a second SIGTERM as "exit at once, without a
# checkpoint"); otherwise CMD's whole process group is stopped (a pipeline in bash -c).
step() {
    local name=$1 limit=$(($2 * SLACK)) t0 rc start
    shift 2
    t0=$(date +%s%N)
    start=$(date -u +%H:%M:%S.%N | cut -c1-12)
    local how=()
    [ "${STEP_FG:-0}" = 1 ] && how=(--foreground --preserve-status)
    timeout "${how[@]}" --kill-after="${STEP_KILL:-2}" "$limit" "$@"
    rc=$?
    printf '%s\t%s\t%s ms\t%s\n' "$name" "$rc" "$((($(date +%s%N) - t0) / 1000000))" "$start" >> "$STEPS"
    [[ " ${STEP_OK:-0} " == *" $rc "* ]] || FAILED=1
    return "$rc"
}

# bench NAME LIMIT_S ARGS...: one `sweep bench --json` line into bench.jsonl, named.
bench() {
    local name=$1 limit=$2
    shift 2
    echo "== $name" >> "$OUT/bench-errors.txt"
    step "bench $name" "$limit" bash -c 'set -o pipefail; "$@" 2>> "$0/bench-errors.txt" |
        sed "s/^{/{\"run\":\"'"$name"'\",/" >> "$0/bench.jsonl"' "$OUT" \
        "$B" bench --json --db "$P/bench.db" "$@" "${SOFT[@]}"
}

# bench NAME LIMIT_S ARGS...: as bench, not stored in the bench database, so that `sweep plan`
# rates the campaigns from the default engine (the variants are timed beside it).
variant() {
    local name=$1 limit=$2
    shift 2
    bench "$name" "$limit" "$@" --no-store
}

run() {
    local software=0
    [ "${1:-}" = "--software" ] && software=1
    mkdir -p "$OUT"
    : > "$STEPS"
    export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
    B=$PWD/$GL/bin/sweep
    SUITE=$PWD/$GL/bin/suite
    # The suite's CLI tests run this binary, not the path compiled into them.
    export SWEEP_TEST_BIN=$B
    if [ ! -x "$B" ] || [ ! -x "$SUITE" ]; then
        echo "run: $GL/bin/sweep and $GL/bin/suite are missing: \`scripts/gpu-device-check.sh prepare\` first" | tee "$OUT/info.txt"
        exit 1
    fi
    P=$(mktemp -d /tmp/sweep-device.XXXX)
    SOFT=()
    export WGPU_BACKEND=vulkan
    if [ "$software" = 1 ]; then
        SOFT=(--allow-software-gpu)
        export SWEEP_ALLOW_SOFTWARE_GPU=1
        SLACK=2
        # Sizes lavapipe runs in seconds (one binding there holds 128 MiB).
        SIZES="3000 10000 30000"; BATCH_N=3000; RODS_N=3000; MIN_S=0.5; VARIANT_N=3000
        CHUNK=50; PAPER_S=5; TEST_THREADS=1
        # A line naming lavapipe's Vulkan adapter, then its "usable: software" line.
        WANT='Vulkan, Cpu'; USABLE='usable: software'
        # lavapipe takes minutes for one of the paper job's chunks (the interrupt is looked at
        # between chunks): killed there is expected too.
        PAPER_OK="0 75 137"; PAPER_KILL=2
        # The tests that run in seconds on lavapipe (the whole GPU suite runs in the test command).
        TESTS=(gpu::one_step_forces gpu_rods::one_step_forces); LONG_TESTS=()
    else
        for f in "$GL"/*.deb; do timeout 5 dpkg -x "$f" / 2>/dev/null; done
        timeout 5 ldconfig 2>/dev/null
        export VK_DRIVER_FILES=${VK_DRIVER_FILES:-/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json}
        export VK_ICD_FILENAMES=$VK_DRIVER_FILES
        export SWEEP_TEST_GPU=hardware
        SLACK=1
        SIZES="3000 10000 30000 100000 1000000"; BATCH_N=30000; RODS_N=100000; MIN_S=1
        # 500 steps a chunk: 8 submissions of the default 64 steps, so the steps-per-submission
        # variant changes something, and a chunk end's closing passes and read-back weigh what
        # they weigh in a campaign's longer chunks at most.
        VARIANT_N=100000; CHUNK=500; PAPER_S=25; TEST_THREADS=4
        WANT='Vulkan, (DiscreteGpu|IntegratedGpu)'; USABLE='usable: hardware'
        PAPER_OK="0 75"; PAPER_KILL=10
        TESTS=(gpu); LONG_TESTS=(gpu)
    fi

    # 1. Find the GPU (within 30 s): a usable Vulkan adapter of the wanted kind, else the
    # loader's word.
    { date -u; timeout 5 nvidia-smi -L 2>&1; } > "$OUT/info.txt"
    step info 10 "$B" info >> "$OUT/info.txt" 2>&1
    if ! awk -v want="$WANT" -v usable="$USABLE" '
        /^  \[[0-9]+\] / { kind = ($0 ~ ("— " want)) }
        kind && index($0, usable) { found = 1 }
        END { exit !found }' "$OUT/info.txt"; then
        {
            echo "== no usable Vulkan adapter of the kind wanted ($WANT, $USABLE)"
            ls -l "$(dirname "${VK_DRIVER_FILES:-/usr/share/vulkan/icd.d/x}")" 2>&1
            ldconfig -p | grep -i vulkan
            VK_LOADER_DEBUG=error,warn,driver timeout --kill-after=2 8 "$B" info 2>&1 | tail -40
        } >> "$OUT/info.txt" 2>&1
        echo "no usable adapter: see $OUT/info.txt"
        exit 3
    fi
    if command -v nvidia-smi >/dev/null 2>&1; then
        nvidia-smi --query-gpu=timestamp,utilization.gpu,memory.used --format=csv -lms 250 \
            > "$OUT/smi.csv" 2>/dev/null &
    fi

    # 2. Correctness on the device: the suite's GPU tests (GPU against CPU f32, conservation,
    # determinism). The stability cases first (run by name, they would come last and be cut
    # first), then the rest, then the long tier on hardware.
    step tests-stability 20 "$SUITE" stability::gpu --test-threads="$TEST_THREADS" \
        > "$OUT/tests.txt" 2>&1
    step tests 40 "$SUITE" "${TESTS[@]}" --skip stability:: --test-threads="$TEST_THREADS" \
        >> "$OUT/tests.txt" 2>&1
    if [ ${#LONG_TESTS[@]} -gt 0 ]; then
        step tests-long 25 "$SUITE" "${LONG_TESTS[@]}" --ignored --test-threads="$TEST_THREADS" \
            >> "$OUT/tests.txt" 2>&1
    fi

    # 3. Throughput: sizes, 16 batched jobs, rods; the CPU beside them for ratios.
    for n in $SIZES; do
        local limit=8
        [ "$n" -ge 100000 ] && limit=11
        bench "silo-$n" "$limit" --backend gpu --scene silo-bed --particles "$n" --steps "$CHUNK" \
            --min-seconds "$MIN_S"
    done
    bench "silo-$BATCH_N-batch16" 12 --backend gpu --scene silo-bed --particles "$BATCH_N" \
        --steps "$CHUNK" --batch 16 --min-seconds "$MIN_S"
    bench "rods-$RODS_N" 9 --backend gpu --scene chute-rods --particles "$RODS_N" \
        --steps "$CHUNK" --min-seconds "$MIN_S"
    bench "cpu-silo-$BATCH_N" 6 --backend cpu --scene silo-bed --particles "$BATCH_N" \
        --steps 20 --min-seconds "$MIN_S"
    # The variants (runner/gpu_variants.rs), each beside the default at the same size: steps
    # per command buffer, list builds without the sort by cell, and one dispatch per step.
    SWEEP_GPU_STEPS_PER_SUBMIT=256 variant "silo-$VARIANT_N-submit256" 8 --backend gpu \
        --scene silo-bed --particles "$VARIANT_N" --steps "$CHUNK" --min-seconds "$MIN_S"
    SWEEP_GPU_SORT_BY_CELL=0 variant "silo-$VARIANT_N-unsorted" 8 --backend gpu \
        --scene silo-bed --particles "$VARIANT_N" --steps "$CHUNK" --min-seconds "$MIN_S"
    SWEEP_GPU_FUSED_STEP=1 variant "silo-$VARIANT_N-fused" 8 --backend gpu \
        --scene silo-bed --particles "$VARIANT_N" --steps "$CHUNK" --min-seconds "$MIN_S"
    SWEEP_GPU_FUSED_STEP=1 variant "rods-$RODS_N-fused" 8 --backend gpu --scene chute-rods \
        --particles "$RODS_N" --steps "$CHUNK" --min-seconds "$MIN_S"

    # 4. Paper scale: one silo job for a bounded time (its checkpoints stay out of $OUT), then
    # the paper campaigns' forecasts from the rates just measured (the bench nearest each
    # job's N).
    # Stopped at its limit it finishes its chunk, checkpoints and exits 75 (paused): the
    # expected end; it has 10 s for that (a chunk of a paper-size job is about a second there).
    STEP_FG=1 STEP_KILL=$PAPER_KILL STEP_OK=$PAPER_OK step paper-job "$PAPER_S" "$B" launch campaigns/silo_paper_one_gpu.json --db "$P/paper.db" \
        --backend gpu "${SOFT[@]}" > "$OUT/paper.txt" 2>&1
    step paper-status 2 "$B" status --db "$P/paper.db" >> "$OUT/paper.txt" 2>&1
    for c in silo_QvsF chute_DvsShear; do
        step "plan $c" 4 "$B" plan "campaigns/$c.json" --db "$P/bench.db" --backend gpu \
            >> "$OUT/paper.txt" 2>&1
    done
    kill %1 2>/dev/null
    cat "$STEPS"
    exit "$FAILED"
}

case "${1:-}" in
    prepare) prepare ;;
    run) shift; run "$@" ;;
    *) echo "usage: $0 prepare | run [--software]" >&2; exit 2 ;;
esac
