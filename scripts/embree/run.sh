#!/usr/bin/env bash
# Single-threaded closest-hit throughput, Embree 3 vs stokes, on the stored ray sets
# (benches/data/rays/). Embree is not a dependency of stokes: without it this script says so and
# exits 0 (skipped).
#
#   scripts/embree/run.sh [--install] [--rounds N] [--reps N] [--quality Q[,Q]] [--pin CPU]
#                         [--control] [RAYSET ...]
#
#   --install     apt-get install libembree-dev (Embree 3) first if it is missing
#   --rounds N    rounds of Embree and stokes (default 3); the first table shows the median
#                 over rounds of each process's median, the second the paired ratio: the median
#                 of the per-round ratios stokes / Embree (each round's two processes run one
#                 right after the other, so a slow spell of a shared machine hits both; which
#                 runs first turns from round to round), their range and how many rounds
#                 reached the goal (docs/performance.md, "The goals")
#   --reps N      timed passes over all rays inside each process (default 5)
#   --quality Q   Embree build qualities: high, medium, low, comma separated (default high,medium)
#   --pin CPU     run both harnesses under `taskset -c CPU`
#   --control     also run stokes a second time each round and print the paired ratio of the
#                 two stokes runs (an A/A control: how much this run's ratios move with no
#                 change at all; on a noisy machine, read the verdicts against it)
#   RAYSET        names in benches/data/rays or target/rays (examples/make_rayset writes soup1m,
#                 sphere1m, grid1m there); default: cbox soup100k and every other *_tris.bin
#
# Embree: scripts/embree/raybench.c (cc -O3 -march=native) -> target/embree-raybench, one
# thread, rtcIntersect1, device config "threads=1" (single-threaded build), FTZ/DAZ on. It also
# checks its hits against the stored reference hits.
# stokes: target/release/examples/raybench SET N_RAYS REPS, which builds as a scene does by
# default (`accel.quality` auto: the high build up to 250 000 primitives, medium above) and
# prints the build time, on one worker thread like Embree's (STOKES_BUILD_THREADS sets how
# many; the tree is the same on any number). Set STOKES_PRESET to medium or high (or another
# obvhs preset, see examples/raybench.rs) to time that build, EMBREE_CONFIG to change the Embree
# device config (default "threads=1"; e.g. "threads=1,isa=avx2").
set -u
cd "$(dirname "$0")/../.." || exit 1

install=0
rounds=3
reps=5
quality=high,medium
pin=()
control=0
sets=()
# an option's value must follow it
need() { [ $# -ge 2 ] || { echo "$1 needs a value (see --help)" >&2; exit 2; }; }
while [ $# -gt 0 ]; do
  case "$1" in
    --install) install=1; shift ;;
    --rounds) need "$@"; rounds="$2"; shift 2 ;;
    --reps) need "$@"; reps="$2"; shift 2 ;;
    --quality) need "$@"; quality="$2"; shift 2 ;;
    --pin) need "$@"; pin=(taskset -c "$2"); shift 2 ;;
    --control) control=1; shift ;;
    -h|--help) awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "$0"; exit 0 ;;
    -*) echo "unknown option $1 (see --help)" >&2; exit 2 ;;
    *) sets+=("$1"); shift ;;
  esac
done

for v in "rounds=$rounds" "reps=$reps"; do
  case "${v#*=}" in
    '' | *[!0-9]* | 0) echo "--${v%%=*} ${v#*=}: not a positive whole number" >&2; exit 2 ;;
  esac
done

have_embree() {
  pkg-config --exists embree3 2>/dev/null || [ -f /usr/include/embree3/rtcore.h ]
}

if ! have_embree; then
  if [ "$install" = 1 ]; then
    sudo=()
    [ "$(id -u)" = 0 ] || sudo=(sudo)
    "${sudo[@]}" apt-get install -y libembree-dev || exit 1
  else
    echo "Embree 3 not installed (apt-get install libembree-dev); skipped (run with --install to install it)"
    exit 0
  fi
fi

target=${CARGO_TARGET_DIR:-target}
# A stored set (benches/data/rays), else one written by examples/make_rayset (target/rays).
data_of() {
  if [ -f "benches/data/rays/$1_tris.bin" ]; then echo benches/data/rays; else echo "$target/rays"; fi
}
if [ ${#sets[@]} -eq 0 ]; then
  sets=(cbox soup100k)
  for f in benches/data/rays/*_tris.bin "$target"/rays/*_tris.bin; do
    [ -f "$f" ] || continue
    s=$(basename "$f" _tris.bin)
    case " ${sets[*]} " in *" $s "*) ;; *) sets+=("$s") ;; esac
  done
fi
for s in "${sets[@]}"; do
  data=$(data_of "$s")
  for part in tris rays hits_t hits_prim; do
    [ -f "$data/${s}_$part.bin" ] || { echo "missing $data/${s}_$part.bin (examples/make_rayset writes soup1m, sphere1m, grid1m)" >&2; exit 1; }
  done
done

mkdir -p "$target"
ebin=$target/embree-raybench
if pkg-config --exists embree3 2>/dev/null; then
  read -r -a eflags <<<"$(pkg-config --cflags --libs embree3)"
else
  eflags=(-lembree3)
fi
cc -O3 -march=native -Wall scripts/embree/raybench.c -o "$ebin" "${eflags[@]}" -lm || exit 1
cargo build --release --quiet --example raybench || exit 1
sbin=$target/release/examples/raybench
# The AVX2 node visits must be inlined into the traversal loops (src/geometry/bvh/nodes.rs,
# `WideNode::visit`); called out of line they cost about a fifth more instructions a ray.
if command -v nm > /dev/null && nm "$sbin" | grep -q 'visit_\(full\|quantised\)_avx\(2\|512\)'; then
  echo "warning: $sbin calls the BVH node visits out of line; its speed is not representative" >&2
fi

median() {
  printf '%s\n' "$@" | sort -g | awk '{ a[NR] = $1 }
    END { if (NR == 0) print "nan"; else if (NR % 2) print a[(NR + 1) / 2];
          else print (a[NR / 2] + a[NR / 2 + 1]) / 2 }'
}

IFS=, read -r -a quals <<<"$quality"
log=$target/embree-raybench.log
: >"$log"
echo "$(nproc) CPUs, load average: $(cut -d' ' -f1-3 /proc/loadavg)" | tee -a "$log"
declare -A emed smed sbuild squal ebuild echk schk ntris eround pratio sround cround cratio
sisa=
checks=()
# Embree on set $1 in round $2 (all requested qualities in one process, one scene each).
run_embree() {
  local s=$1 r=$2 out tag qual rest q m
  out=$("${pin[@]}" "$ebin" -d "$(data_of "$s")" -c "${EMBREE_CONFIG-threads=1}" -q "$quality" \
    -r "$reps" "$s") || exit 1
  printf '%s\n' "$out" >>"$log"
  while read -r tag _ qual rest; do
    q=${qual#quality=}
    case "$tag" in
      embree)
        m=$(sed -n 's/.* median \([0-9.]*\) Mrays.*/\1/p' <<<"$rest")
        emed[$s,$q]+=" $m"
        eround[$s,$q]=$m
        ebuild[$s,$q]+=" $(sed -n 's/.*build_ms=\([0-9.]*\).*/\1/p' <<<"$rest")"
        echk[$s]=$(sed -n 's/.* chk \([0-9.]*\).*/\1/p' <<<"$rest")
        ntris[$s]=$(sed -n 's/.*tris=\([0-9]*\).*/\1/p' <<<"$rest")
        echo "round $r: embree $s $q median $m Mrays/s" ;;
      check)
        [ "$r" = 1 ] && checks+=("$s $q: $rest") ;;
    esac
  done <<<"$out"
}

# stokes on set $1 in round $2; $3 = control for the second, control process (--control).
run_stokes() {
  local s=$1 r=$2 out m
  out=$(env -u LEAF -u REINS -u NOSPLIT -u LAYOUT PRESET="${STOKES_PRESET:-auto}" \
    RAYON_NUM_THREADS="${STOKES_BUILD_THREADS:-1}" \
    "${pin[@]}" "$sbin" "$s" 100000000 "$reps" 2>&1) || { echo "$out" >&2; exit 1; }
  printf '%s\n' "$out" >>"$log"
  m=$(sed -n 's/.* median \([0-9.]*\) Mrays.*/\1/p' <<<"$out")
  if [ "${3-}" = control ]; then
    cround[$s]=$m
    echo "round $r: stokes $s median $m Mrays/s (control)"
    return
  fi
  sround[$s]=$m
  smed[$s]+=" $m"
  sbuild[$s]+=" $(sed -n 's/^build [a-z_]* \([0-9.]*\) ms.*/\1/p' <<<"$out")"
  squal[$s]=$(sed -n 's/^build \([a-z_]*\) [0-9.]* ms.*/\1/p' <<<"$out")
  schk[$s]=$(sed -n 's/.* chk \([0-9.]*\).*/\1/p' <<<"$out")
  sisa=$(sed -n 's/^isa //p' <<<"$out")
  echo "round $r: stokes $s median $m Mrays/s"
}

# Each round runs the processes one right after the other, in an order that turns from round to
# round (Embree first in round 1, stokes first in round 2, ...), so that neither side always
# follows the other.
order=(embree stokes)
[ "$control" = 1 ] && order+=(control)
for ((r = 1; r <= rounds; r++)); do
  for s in "${sets[@]}"; do
    for ((k = 0; k < ${#order[@]}; k++)); do
      case "${order[$(((r - 1 + k) % ${#order[@]}))]}" in
        embree) run_embree "$s" "$r" ;;
        stokes) run_stokes "$s" "$r" ;;
        control) run_stokes "$s" "$r" control ;;
      esac
    done
    for q in "${quals[@]}"; do
      pratio[$s,$q]+=" $(awk -v a="${sround[$s]}" -v b="${eround[$s,$q]}" 'BEGIN { printf "%.4f", a / b }')"
    done
    if [ "$control" = 1 ]; then
      cratio[$s]+=" $(awk -v a="${cround[$s]}" -v b="${sround[$s]}" 'BEGIN { printf "%.4f", a / b }')"
    fi
  done
done

echo
# family, model and L2 too: virtual machines report a bare "AMD EPYC" for several generations
cpu_fam=$(sed -n 's/^cpu family[[:space:]]*: //p' /proc/cpuinfo | head -1)
cpu_mod=$(sed -n 's/^model[[:space:]]*: //p' /proc/cpuinfo | head -1)
cpu_l2=$(cat /sys/devices/system/cpu/cpu0/cache/index2/size 2>/dev/null)
echo "CPU: $(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1) (family ${cpu_fam:-?} model ${cpu_mod:-?}, L2 ${cpu_l2:-?} a core); stokes instruction set: ${sisa:-unknown} (STOKES_ISA forces a lower one)"
echo "Closest hit, 1 thread, Mrays/s (median over $rounds rounds of the median of $reps passes);"
echo "build times in ms (median over rounds; Embree device threads=1, stokes on ${STOKES_BUILD_THREADS:-1} thread(s))"
hdr=$(printf '%-10s %8s' "ray set" "tris")
for q in "${quals[@]}"; do hdr+=$(printf ' %13s' "Embree $q"); done
hdr+=$(printf ' %9s' "stokes")
for q in "${quals[@]}"; do hdr+=$(printf ' %13s' "stokes/$q"); done
echo "$hdr"
for s in "${sets[@]}"; do
  sm=$(median ${smed[$s]})
  line=$(printf '%-10s %8s' "$s" "${ntris[$s]}")
  for q in "${quals[@]}"; do line+=$(printf ' %13.3f' "$(median ${emed[$s,$q]})"); done
  line+=$(printf ' %9.3f' "$sm")
  for q in "${quals[@]}"; do
    line+=$(printf ' %13.3f' "$(awk -v a="$sm" -v b="$(median ${emed[$s,$q]})" 'BEGIN { print a / b }')")
  done
  echo "$line"
done
echo
# The goal of docs/performance.md: at least Embree medium's speed on the large meshes, twice it
# on the 32-triangle Cornell box (traced by the flat loop of tiny scenes).
goal_of() { case "$1" in cbox) echo 2 ;; *) echo 1 ;; esac; }
echo "Paired ratio stokes / Embree: median of the $rounds per-round ratios (range; rounds at or above the goal)"
for s in "${sets[@]}"; do
  line=$(printf '%-10s' "$s")
  for q in "${quals[@]}"; do
    # shellcheck disable=SC2086
    line+=$(printf '%s\n' ${pratio[$s,$q]} | sort -g | awk -v q="$q" -v goal="$(goal_of "$s")" \
      '{ a[NR] = $1; n += ($1 >= goal) }
       END { med = NR % 2 ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2
             printf "  %s %.3f (%.3f-%.3f; %d of %d >= %gx)", q, med, a[1], a[NR], n, NR, goal }')
  done
  echo "$line"
done
if [ "$control" = 1 ]; then
  echo "Control: stokes / stokes, the same binary twice a round (median of the $rounds per-round ratios;"
  echo "quartiles; range): how far this run's ratios move without any change"
  for s in "${sets[@]}"; do
    # shellcheck disable=SC2086
    printf '%s\n' ${cratio[$s]} | sort -g | awk -v s="$s" \
      '{ a[NR] = $1 }
       END { med = NR % 2 ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2
             printf "%-10s control %.3f (quartiles %.3f-%.3f; range %.3f-%.3f)\n", s, med,
               a[int(NR / 4) + 1], a[int((3 * NR + 3) / 4)], a[1], a[NR] }'
  done
fi
echo
printf '%-10s' "build ms"
for q in "${quals[@]}"; do printf ' %13s' "Embree $q"; done
printf ' %9s\n' "stokes (quality)"
for s in "${sets[@]}"; do
  printf '%-10s' "$s"
  for q in "${quals[@]}"; do printf ' %13.2f' "$(median ${ebuild[$s,$q]})"; done
  printf ' %9.2f (%s)\n' "$(median ${sbuild[$s]})" "${squal[$s]}"
done
echo
echo "Embree vs the stored reference hits (round 1; t relative 1e-4 + 1e-6, ties allowed):"
printf '  %s\n' "${checks[@]}"
echo "Sum of hit t over all rays (chk), Embree vs stokes:"
for s in "${sets[@]}"; do
  awk -v s="$s" -v e="${echk[$s]}" -v k="${schk[$s]}" \
    'BEGIN { printf "  %-10s Embree %.3f  stokes %.3f  rel. diff %.2e\n", s, e, k, (k - e) / e }'
done
echo "Raw output: $log"
