#!/usr/bin/env bash
# The bevy plugin's windowed example, smoke-run (issue 40): built with its
# `example-app` feature (bevy's renderer, winit on X11, text), then
# run for a few frames under Xvfb on Mesa's lavapipe (no GPU, no display),
# saving a screenshot. Fails when it does not start, crash, or cull nothing.
#
#   scripts/bevy-example-check.sh [FRAMES]   (default 40; the screenshot in target/hom-bevy-city.png)
set -euo pipefail
cd "$(dirname "$0")/.."
frames="${1:-40}"
scripts/install-graphics.sh
# (`.ci/run` lints the example with the workspace.)
cargo build -p hom-bevy --features example-app --example city
shot="$PWD/target/hom-bevy-city.png"
rm -f "$shot"
log="$(mktemp)"
# lavapipe through Vulkan; XDG_RUNTIME_DIR only quiets a warning.
if ! HOM_BEVY_FRAMES="$frames" HOM_BEVY_SCREENSHOT="$shot" WGPU_BACKEND=vulkan XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}" \
    timeout 600 xvfb-run -a -s "-screen 0 1280x720x24" target/debug/examples/city >"$log" 2>&1; then
    tail -n 30 "$log" >&2
    echo "bevy-example-check: the city example failed under Xvfb" >&2
    exit 1
fi
grep -E '^(after|entities)' "$log"
occluded="$(sed -n 's/^entities [0-9]*, occluded \([0-9]*\)$/\1/p' "$log")"
if [[ -z "$occluded" || "$occluded" -eq 0 ]]; then
    tail -n 30 "$log" >&2
    echo "bevy-example-check: the example culled nothing" >&2
    exit 1
fi
if [[ ! -s "$shot" ]]; then
    echo "bevy-example-check: no screenshot at $shot" >&2
    exit 1
fi
echo "bevy-example-check: ok ($occluded meshes occluded; screenshot $shot)"
