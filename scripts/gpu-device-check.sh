#!/usr/bin/env bash
# Everything issue 26 measures on a lent GPU machine, in one `run` call of the device tool
# (../shared/notes/gpu-device.md): carry [".gl", "target/release/sweep"], timeout_s ~560.
# Writes under $OUT: info.txt (adapters), bench.jsonl (one JSON line per bench), paper.txt (one
# paper-scale silo job: 1 s fill at most, 0.5 s of discharge), errors.txt.
set -u
OUT=${OUT:-/tmp/gpu-out}
mkdir -p "$OUT"
for f in .gl/*.deb; do dpkg -x "$f" / 2>/dev/null; done
ldconfig 2>/dev/null
export VK_DRIVER_FILES=${VK_DRIVER_FILES:-/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json}
B=./target/release/sweep
{ date -u; nvidia-smi -L; $B info; } > "$OUT/info.txt" 2>&1
bench() { # limit name args...
  local limit=$1 name=$2; shift 2
  echo "== $name" >> "$OUT/errors.txt"
  timeout "$limit" $B bench --no-store --json "$@" 2>> "$OUT/errors.txt" \
    | sed "s/^{/{\"run\":\"$name\",/" >> "$OUT/bench.jsonl"
}
bench 60 silo30k --backend gpu --scene silo-bed --particles 30000 --steps 3000
bench 90 silo30k-batch16 --backend gpu --scene silo-bed --particles 30000 --steps 1000 --batch 16
bench 90 silo1m --backend gpu --scene silo-bed --particles 1000000 --steps 300
bench 60 rods100k --backend gpu --scene chute-rods --particles 100000 --steps 1000
bench 60 cpu16-silo30k --backend cpu --threads 16 --scene silo-bed --particles 30000 --steps 300
# The job's database and work directory (checkpoints) stay out of $OUT: only the text comes back.
P=/tmp/sweep-paper
mkdir -p "$P"
timeout 200 $B launch campaigns/silo_paper_one_gpu.json --db "$P/paper.db" --backend gpu \
  > "$OUT/paper.txt" 2>&1
$B status --db "$P/paper.db" >> "$OUT/paper.txt" 2>&1
