#!/usr/bin/env bash
# sweep against LAMMPS on the same sphere chute (issue 24): d = m = g = 1, k_n = 2e5, e_n = 0.88,
# mu = 0.5, a 10 d x 10 d periodic box over sweep's rough base, a bed of about 20 d (2101
# spheres), dt = t_c/50, f64 in both. `sweep plan --lammps` writes the job's exact initial state
# (START: "bagnold", the warm start, or "pour", the loose gas at rest), law, gravity, dt and box
# for LAMMPS (gran/hooke/history); both codes run it to T1, recording the kinetic energy, and
# profiles every 0.5 time units, and scripts/chute_compare.py compares the window [T0, T1] in
# blocks of BLOCK time units (V_x within 5 % above z = 4 d, phi within 0.02 in the bulk).
# Needs LAMMPS with its GRANULAR package: Debian's `lammps` has it (installed here when missing
# and running as root). Results stay in OUT (default target/chute-lammps/ALPHA-START).
# WARM_I is the warm start's inertial number (0.14: between the 24-degree runs from 0.1, which
# rise, and from 0.2, which fall; docs/chute-lammps.md).
# usage: [LMP=lmp] [NP=2] [WARM_I=0.14] [OUT=dir] scripts/compare-lammps-chute.sh [ALPHA] [START] [T0] [T1] [BLOCK]
set -euo pipefail
cd "$(dirname "$0")/.."
alpha=${1:-24}
start=${2:-bagnold}
t0=${3:-40}
t1=${4:-80}
block=${5:-5}
lmp=${LMP:-lmp}
np=${NP:-2}
warm_i=${WARM_I:-0.14}
if ! command -v "$lmp" >/dev/null; then
  [ "$(id -u)" = 0 ] || { echo "compare-lammps-chute: LAMMPS (lmp) not found; install Debian's lammps" >&2; exit 2; }
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq lammps >/dev/null
fi
cargo build --release --bin sweep -q
bin=$PWD/target/release/sweep
out=${OUT:-$PWD/target/chute-lammps/$alpha-$start}
rm -rf "$out"
mkdir -p "$out"
# steady_min_time_s = steady_max_time_s = T0 and measure_unsteady: sweep measures [T0, T1]
# whatever its detector says (at any angle, steady or not), the window LAMMPS is compared on.
cat >"$out/chute.json" <<EOF
{
  "name": "chute_lammps_${alpha}_${start}",
  "scene": "chute",
  "description": "sweep against LAMMPS (scripts/compare-lammps-chute.sh): issue 24's sphere chute.",
  "base": {
    "aspect_ratio": 1.0,
    "particle_length_m": 1.0,
    "particle_density_kg_per_m3": 1.909859317102744,
    "gravity_m_per_s2": 1.0,
    "box_x_lengths": 10.0,
    "box_y_lengths": 10.0,
    "bed_height_lengths": 20.0,
    "inclination_deg": $alpha,
    "initial_state": "$start",
    "warm_inertial_number": $warm_i,
    "steady_min_time_s": $t0,
    "steady_max_time_s": $t0,
    "measure_time_s": $(python3 -c "print($t1 - $t0)"),
    "measure_unsteady": true
  },
  "observers": {"snapshots": {"interval_s": 0.5}, "chute": {"sample_interval_s": 0.5}},
  "run": {"precision": "f64", "checkpoint_interval_s": 20.0}
}
EOF
"$bin" plan "$out/chute.json" --db "$out/plan.db" --lammps "$out/lammps" | grep -E 'LAMMPS|^ +1 '
echo "== sweep (2 threads)"
/usr/bin/time -f "sweep: %e s" "$bin" launch "$out/chute.json" --db "$out/sweep.db" --threads 2 --backend cpu 2>&1 |
  grep -E 'steady|done|failed|sweep:'
mpi=(mpirun -np "$np")
[ "$(id -u)" = 0 ] && mpi+=(--allow-run-as-root)
echo "== LAMMPS ($np processes): $("$lmp" -h | grep -m1 -i 'Large-scale' | xargs)"
(cd "$out/lammps/job-1" && /usr/bin/time -f "LAMMPS: %e s" "${mpi[@]}" "$lmp" -in in.chute -log log.lammps -screen none)
frames=$(ls -d "$out"/sweep-work/*/jobs/*/snapshots)
# Exit status: 0 pass, 1 fail, 3 not comparable (a code did not run through the window).
python3 scripts/chute_compare.py "$out/sweep.db" "$frames" "$out/lammps/job-1" --t0 "$t0" --t1 "$t1" \
  --block "$block" | tee "$out/result.md"
exit "${PIPESTATUS[0]}"
