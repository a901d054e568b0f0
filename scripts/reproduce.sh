#!/usr/bin/env bash
# Regenerate every row of results/REPRODUCTION.md: every experiment in experiments/, the renders
# and analyses of the papers' figures that are single images (results/reproduction/), the data
# plots (examples/paper_plots/) and Hua 2022's colour evaluation.
#
#   scripts/reproduce.sh                  everything (about two and a half hours on 2 cores)
#   scripts/reproduce.sh --quick          the same at 64x48 and a few spp (minutes)
#   scripts/reproduce.sh --only NAME...   some parts: experiment names, `renders`, `plots`, `bench`,
#                                         `gmm`
#   scripts/reproduce.sh --out DIR        results root (default: results, or results/quick)
#
# Experiments whose integrators are not built fail with exit code 2 and a message naming the
# integrator; the script reports every failure and carries on. Exit status 1 if any part failed.
set -u
cd "$(dirname "$0")/.."

quick=()
out=
only=()
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) quick=(--quick); shift ;;
    --out) out="$2"; shift 2 ;;
    --only) shift; while [ $# -gt 0 ] && [ "${1#--}" = "$1" ]; do only+=("$1"); shift; done ;;
    *) echo "usage: $0 [--quick] [--out DIR] [--only NAME...]" >&2; exit 2 ;;
  esac
done

if [ -z "$out" ]; then
  if [ ${#quick[@]} -gt 0 ]; then out=results/quick; else out=results; fi
fi

wanted() {
  [ ${#only[@]} -eq 0 ] && return 0
  local n
  for n in "${only[@]}"; do [ "$n" = "$1" ] && return 0; done
  return 1
}

cargo build --release --quiet || exit 1
bin=target/release/stokes

experiments=(
  walls-integrators
  walls-resets
  walls-wavelength-sampling
  hero-vs-mono-green
  hero-vs-mono-uv
  hero-vs-mono-checker
  hero-vs-mono-medium
  fluorescence-parameters
  bin-width
  media-teaser
  media-tracking
  media-tracking-scattering
  media-tracking-inshift
  media-tracking-chromatic
  media-absorption-sweep
  media-emission-width
  media-integrators-walls-fog
  media-integrators-divider
  media-integrators-cube
  gmm-vs-matrix
  gmm-sampling
  hero-lanes-walls
  hero-lanes-green
  hero-lanes-medium
)

failed=()
for e in "${experiments[@]}"; do
  wanted "$e" || continue
  echo "== $e ${quick[*]}"
  start=$(date +%s)
  if "$bin" experiment "experiments/$e.json" --out "$out" "${quick[@]}"; then
    "$bin" figures "$out/$e" > /dev/null || failed+=("$e (figures)")
    echo "   done in $(( $(date +%s) - start )) s: $out/$e/$(cat "$out/$e/latest")"
  else
    failed+=("$e")
  fi
done

# Single renders and analyses (results/reproduction/): images of the figures that are not a
# comparison of estimators. EXRs go to $out/reproduction/exr (not committed), PNGs and JSON beside.
renders() {
  local r="$out/reproduction" x="$out/reproduction/exr"
  mkdir -p "$x" || return 1
  # spp: full, quick
  local s_img=256 s_smoke=128 s_walls=1024 s_green=34 size=()
  if [ ${#quick[@]} -gt 0 ]; then
    s_img=4 s_smoke=4 s_walls=8 s_green=2
    size=(--set camera.width=64 --set camera.height=48)
  fi
  local R=("$bin" render --quiet --threads 2 "${size[@]}")
  set -e
  # pt-hero renders keep 4 lanes, the hero wavelength count of Mojzík's figures (the default is 8)
  # Mojzík Fig. 11: the cube in white light (a), under light inside (c) and outside (e) the
  # absorption band, and each minus the same scene without the fluorophore (d, f).
  "${R[@]}" scenes/media-cube.json --integrator pt-hero --lanes 4 --spp "$s_img" -o "$x/fig11a.exr" --png "$r/mojzik-fig11a.png"
  for band in 450 600; do
    "${R[@]}" "scenes/media-cube-$band.json" --integrator pt-hero --lanes 4 --spp "$s_img" \
      -o "$x/fig11-$band.exr" --png "$r/mojzik-fig11-$band.png"
    "${R[@]}" "scenes/media-cube-$band.json" --integrator pt-hero --lanes 4 --spp "$s_img" \
      --set media.dye.fluorescence.concentration=0 -o "$x/fig11-$band-clear.exr"
    "$bin" diff "$x/fig11-$band.exr" "$x/fig11-$band-clear.exr" -o "$r/mojzik-fig11-$band-difference.png" \
      --title "Mojzík Fig. 11 ($band nm light): fluorescent cube minus the cube without its fluorophore" \
      > "$r/mojzik-fig11-$band-difference.txt"
  done
  # Mojzík Fig. 14: the UV sphere under UV + visible light (a) and visible light only (b).
  "${R[@]}" scenes/uv-sphere.json --integrator pt-hero --lanes 4 --spp "$s_img" -o "$x/fig14a.exr" --png "$r/mojzik-fig14a.png"
  "${R[@]}" scenes/uv-sphere-visible.json --integrator pt-hero --lanes 4 --spp "$s_img" -o "$x/fig14b.exr" --png "$r/mojzik-fig14b.png"
  "$bin" diff "$x/fig14a.exr" "$x/fig14b.exr" -o "$r/mojzik-fig14-difference.png" \
    --title "Mojzík Fig. 14: UV + visible light minus visible light only" > "$r/mojzik-fig14-difference.txt"
  # Mojzík Fig. 15: the fluorescent smoke in the visible (a), in its UV absorption band (b), in
  # its emission band and outside both bands (d), with band sensors; and a spectral image.
  "${R[@]}" scenes/media-smoke.json --integrator pt-hero --lanes 4 --spp "$s_smoke" -o "$x/fig15a.exr" \
    --png "$r/mojzik-fig15a-visible.png" --spectral 25 --stats "$r/mojzik-fig15a-stats.json"
  local band name
  for band in "300,380:uv" "540,580:emission" "600,780:outside"; do
    name=${band#*:}
    "${R[@]}" scenes/media-smoke.json --integrator pt-hero --lanes 4 --spp "$s_smoke" \
      --set "camera.sensor={\"band\":[${band%:*}]}" -o "$x/fig15-$name.exr"
    "$bin" png "$x/fig15-$name.exr" -o "$r/mojzik-fig15-$name.png" > "$r/mojzik-fig15-$name.txt"
  done
  # Jung Fig. 7.4: the walls by path length (full spectral evaluation), one image per vertex count.
  "${R[@]}" scenes/fluorescent-walls.json --integrator bdpt-allbins --spp "$s_walls" -o "$x/walls-allbins.exr" \
    --strategy-images "$x/walls-strategies" --stats "$r/jung-fig7-8-allbins-stats.json"
  local k
  for k in 3 4 5 6; do
    "$bin" png "$x/walls-strategies/vertices$k.exr" -o "$r/jung-fig7-4-vertices$k.png" > "$r/jung-fig7-4-vertices$k.txt"
  done
  # Jung Fig. 7.8: contributing paths with uniform and importance wavelength sampling.
  for ws in uniform importance; do
    "${R[@]}" scenes/fluorescent-walls.json --integrator bdpt-forward --spp "$s_walls" \
      --wavelength-sampling "$ws" -o "$x/walls-$ws.exr" --stats "$r/jung-fig7-8-$ws-stats.json"
  done
  # Jung Figs. 7.14 and 7.15: the sphere scene at 34 spp, uniform and importance sampling, and
  # without fluorescence (the same reflectance, concentration 0).
  for ws in uniform importance; do
    "${R[@]}" scenes/green-spheres.json --integrator bdpt-forward --spp "$s_green" \
      --wavelength-sampling "$ws" -o "$x/green-$ws.exr" --stats "$r/jung-fig7-14-$ws-stats.json"
    "${R[@]}" scenes/green-spheres.json --integrator bdpt-forward --spp "$s_green" \
      --wavelength-sampling "$ws" --set materials.fluorescein.concentration=0 \
      -o "$x/green-$ws-plain.exr" --stats "$r/jung-fig7-14-$ws-plain-stats.json"
  done
  # Mojzík Fig. 18's reversal at σa = 0.2: the variance of one render per camera wavelength
  # band, pt-mono and pt-hero, exponential and aware tracking (and at σa = 0.05 for contrast).
  local vb=(--spp 128 --seeds 8 --size 64 --bins 16)
  [ ${#quick[@]} -gt 0 ] && vb=(--spp 4 --seeds 3 --size 16 --bins 8)
  for sa in 0.2 0.05; do
    cargo run --release --quiet --example variance_breakdown -- scenes/media-divider.json \
      --set "media.fluid.sigma_a=$sa" "${vb[@]}" --csv "$r/mojzik-fig18-variance-sa$sa.csv" \
      > "$r/mojzik-fig18-variance-sa$sa.md"
  done
  set +e
}
if wanted renders; then
  echo "== renders ${quick[*]}"
  (renders) || failed+=("renders")
fi

# The papers' data plots and the walls' scanlines (Jung Fig. 7.3, from the walls render above).
if wanted plots; then
  echo "== plots"
  walls=()
  [ -f "$out/reproduction/exr/walls-allbins.exr" ] && walls=(--walls "$out/reproduction/exr/walls-allbins.exr")
  cargo run --release --quiet --example paper_plots -- "$out/reproduction/plots" "${walls[@]}" \
    || failed+=("plots")
fi

# Jung Fig. 7.14's first row: the cost of a uniform and of a tabulated wavelength draw (criterion;
# about a minute with its build; skipped by --quick, whose point is minutes).
if wanted bench; then
  if [ ${#quick[@]} -gt 0 ]; then
    echo "== bench: skipped with --quick (run: cargo bench --bench wavelengths)"
  else
    echo "== bench"
    cargo bench --quiet --bench wavelengths > "$out/reproduction/jung-fig7-14-wavelengths-bench.txt" 2>&1 \
      || failed+=("bench")
  fi
fi

# Hua 2022's colour evaluation of Gaussian-mixture fits of the 144 RIT matrices and its
# figures (Figs. 4-8; seconds).
if wanted gmm; then
  for method in em bayes; do
    echo "== gmm eval ($method)"
    "$bin" gmm eval data/bispectral/rit --components 2,4,8 --method "$method" \
      -o "$out/gmm-eval/$method" || failed+=("gmm eval $method")
  done
  echo "== gmm figures (em)"
  "$bin" gmm figures data/bispectral/rit --components 2,4,8 --method em \
    -o "$out/gmm-eval/em/figures" || failed+=("gmm figures")
fi

if [ ${#failed[@]} -gt 0 ]; then
  echo "failed: ${failed[*]}" >&2
  exit 1
fi
echo "all done"
