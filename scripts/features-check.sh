#!/usr/bin/env bash
# Check the builds that compile the fluorescence and media code paths out (cargo features
# `fluorescence` and `media`, both default; docs/performance.md): every combination compiles,
# the build without either renders a plain scene bit-identically to the default build, and it
# refuses a fluorescent scene and a scene with a medium with exit 2 and a message naming the
# field. Run by .ci/run; takes about two minutes.
set -euo pipefail
cd "$(dirname "$0")/.."
for f in fluorescence media; do
  cargo check --release --quiet --no-default-features --features "$f" --target-dir target/lean-check
done
cargo build --release --quiet --bin stokes
cargo build --release --quiet --bin stokes --no-default-features --target-dir target/lean
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for i in pt-hero bdpt-forward; do
  target/release/stokes render scenes/cornell-box.json --integrator "$i" --spp 2 --seed 5 \
    -o "$tmp/default.exr" --quiet >/dev/null 2>&1
  target/lean/release/stokes render scenes/cornell-box.json --integrator "$i" --spp 2 --seed 5 \
    -o "$tmp/lean.exr" --quiet >/dev/null 2>&1
  cmp "$tmp/default.exr" "$tmp/lean.exr" || { echo "FAIL: $i differs without the features"; exit 1; }
done
refuse() { # scene, expected text
  set +e
  target/lean/release/stokes render "$1" --spp 1 -o "$tmp/x.exr" --quiet 2>"$tmp/err"
  rc=$?
  set -e
  if [ "$rc" != 2 ] || ! grep -q "$2" "$tmp/err"; then
    echo "FAIL: $1 gave exit $rc: $(cat "$tmp/err")"
    exit 1
  fi
}
refuse scenes/fluorescent-walls.json "field \`materials.ceiling.type\`: this build of stokes has no fluorescent"
refuse scenes/media-cube.json "field \`media.dye\`: this build of stokes has no participating media"
echo "features check: all passed"
