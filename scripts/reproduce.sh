#!/usr/bin/env bash
# Run every experiment in experiments/ and regenerate every figure from the stored results.
#
#   scripts/reproduce.sh            full runs (hours on 2 cores)
#   scripts/reproduce.sh --quick    minutes-long smoke version (64x48, few spp, 1 repeat)
#   scripts/reproduce.sh --out DIR  results root (default: results, or results/quick with --quick)
#
# Experiments whose integrators are not built yet fail with exit code 2 and a message naming the
# integrator; the script reports them and carries on. Exit status: 1 if any experiment failed.
set -u
cd "$(dirname "$0")/.."

quick=()
out=
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) quick=(--quick); shift ;;
    --out) out="$2"; shift 2 ;;
    *) echo "usage: $0 [--quick] [--out DIR]" >&2; exit 2 ;;
  esac
done

if [ -z "$out" ]; then
  if [ ${#quick[@]} -gt 0 ]; then out=results/quick; else out=results; fi
fi

cargo build --release --quiet || exit 1
bin=target/release/stokes

experiments=(
  walls-integrators
  walls-wavelength-sampling
  hero-vs-mono-green
  hero-vs-mono-uv
  fluorescence-parameters
  bin-width
  media-tracking
  media-tracking-scattering
  media-absorption-sweep
  media-emission-width
  media-integrators-walls-fog
  media-integrators-divider
  media-integrators-cube
  gmm-vs-matrix
)

failed=()
for e in "${experiments[@]}"; do
  echo "== $e ${quick[*]}"
  start=$(date +%s)
  if "$bin" experiment "experiments/$e.json" --out "$out" "${quick[@]}"; then
    "$bin" figures "$out/$e" > /dev/null || failed+=("$e (figures)")
    echo "   done in $(( $(date +%s) - start )) s: $out/$e/$(cat "$out/$e/latest")"
  else
    failed+=("$e")
  fi
done

# Hua 2022's colour evaluation of Gaussian-mixture fits of the 144 RIT matrices (seconds).
for method in em bayes; do
  echo "== gmm eval ($method)"
  "$bin" gmm eval data/bispectral/rit --components 2,4,8 --method "$method" \
    -o "$out/gmm-eval/$method" || failed+=("gmm eval $method")
done

if [ ${#failed[@]} -gt 0 ]; then
  echo "failed: ${failed[*]}" >&2
  exit 1
fi
echo "all experiments done"
