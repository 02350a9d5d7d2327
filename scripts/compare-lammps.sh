#!/usr/bin/env bash
# sweep against LAMMPS on the same beds, on this machine: for each scene, `sweep bench --settle
# --lammps` settles the bed (or reuses it from target/bench-db/bench-beds/) and writes it with the
# scene's constants as a LAMMPS input; then sweep (f32 and f64) and LAMMPS (`mpirun -np 2`,
# with `newton off` as written and with `newton on`) run alternately, ROUNDS times, so that the
# VM's slow and fast phases fall on all of them. Prints each run and the medians, in mobile
# particle-steps per second (LAMMPS: mobile spheres x steps / the timed run's loop time).
# Needs LAMMPS with its GRANULAR package: Debian's `lammps` has it (installed here when missing
# and running as root) and runs it with Open MPI. LMP=/path/to/lmp times another build (one
# compiled for this CPU, say) with the same mpirun.
# usage: [LMP=lmp] scripts/compare-lammps.sh [N] [STEPS] [ROUNDS] [SCENES...]
set -euo pipefail
n=${1:-30000}
steps=${2:-300}
rounds=${3:-5}
shift $(($# < 3 ? $# : 3))
scenes=("${@:-chute-bed silo-bed}")
read -r -a scenes <<<"${scenes[*]}"
lmp=${LMP:-lmp}
if ! command -v "$lmp" >/dev/null; then
  [ "$(id -u)" = 0 ] || { echo "compare-lammps: LAMMPS (lmp) not found; install Debian's lammps" >&2; exit 2; }
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq lammps >/dev/null
fi
cargo build --release --bin sweep -q
bin=$PWD/target/release/sweep
db=$PWD/target/bench-db/bench.db
mkdir -p "$(dirname "$db")"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mpi=(mpirun -np 2)
[ "$(id -u)" = 0 ] && mpi+=(--allow-run-as-root)
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs); $("$lmp" -h | grep -m1 -i 'Large-scale' | xargs)"
for scene in "${scenes[@]}"; do
  # The bed (settled once, then reused) and its LAMMPS input.
  mobile=$("$bin" bench --scene "$scene" --particles "$n" --steps "$steps" --settle --no-store \
    --db "$db" --lammps "$work" --json 2>/dev/null |
    python3 -c 'import json,sys; print(json.load(sys.stdin)["particles"])')
  input=$(ls "$work"/in."$scene"-*)
  sed 's/^newton off/newton on/' "$input" >"$input.newton"
  echo "== $scene: $mobile mobile spheres, $steps timed steps after 100"
  for r in $(seq "$rounds"); do
    for p in f32 f64; do
      v=$("$bin" bench --scene "$scene" --particles "$n" --steps "$steps" --settle --threads 2 \
        --precision "$p" --no-store --db "$db" --json 2>/dev/null |
        python3 -c 'import json,sys; print(json.load(sys.stdin)["particle_steps_per_s"])')
      echo "$r sweep-$p-T2 $v"
    done
    for f in "$input" "$input.newton"; do
      name=lammps-np2-newton-off
      [ "$f" = "$input.newton" ] && name=lammps-np2-newton-on
      loop=$(cd "$work" && "${mpi[@]}" "$lmp" -in "$f" -log none 2>&1 | grep 'Loop time' | tail -1 |
        awk '{print $4}')
      echo "$r $name $(python3 -c "print($mobile * $steps / $loop)")"
    done
  done | tee "$work/runs"
  python3 - "$work/runs" <<'EOF'
import sys, statistics, collections
runs = collections.defaultdict(list)
for line in open(sys.argv[1]):
    _, name, v = line.split()
    runs[name].append(float(v))
for name, v in runs.items():
    print(f"median {name:24s} {statistics.median(v):.3e} particle-steps/s "
          f"(min {min(v):.3e}, max {max(v):.3e}, {len(v)} runs)")
EOF
done
