#!/usr/bin/env bash
# Builds hom's C ABI (crates/hom-capi) and, with the system's C and C++
# compilers, its C test, C++ test and C examples against the static library,
# warnings as errors; runs them. CI runs it (`.ci/run`).
#
#   scripts/c-api-check.sh           debug library: the checks
#   scripts/c-api-check.sh --bench   release library: hom-occlusion's `engine_loop`
#                                    and its C port (`c/engine_loop.c`), alternately, three times each
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bench=0
for arg in "$@"; do
    case "$arg" in
        --bench) bench=1 ;;
        -h|--help) sed -n '2,9p' "$0"; exit 0 ;;
        *) echo "c-api-check: unknown option '$arg' (use --bench or --help)" >&2; exit 2 ;;
    esac
done
for tool in cc c++; do
    command -v "$tool" >/dev/null || { echo "c-api-check: '$tool' is needed (Debian: build-essential)" >&2; exit 1; }
done
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
inc=crates/hom-capi/include
libs=(-lpthread -ldl -lm)

if [[ $bench == 1 ]]; then
    cargo build -q --release -p hom-capi --lib
    cargo build -q --release -p hom-occlusion --example engine_loop
    cc -O2 -std=c11 -I"$inc" crates/hom-capi/c/engine_loop.c target/release/libhom_capi.a "${libs[@]}" -o "$out/engine_loop"
    for _ in 1 2 3; do
        target/release/examples/engine_loop | tail -n 1
        "$out/engine_loop"
    done
    exit 0
fi

cargo build -q -p hom-capi --lib
lib=target/debug/libhom_capi.a
cc -Wall -Wextra -Werror -std=c11 -I"$inc" crates/hom-capi/c/test.c "$lib" "${libs[@]}" -o "$out/test"
c++ -Wall -Wextra -Werror -std=c++17 -I"$inc" crates/hom-capi/c/test.cpp "$lib" "${libs[@]}" -o "$out/test_cpp"
cc -Wall -Wextra -Werror -std=c11 -I"$inc" crates/hom-capi/c/example.c "$lib" "${libs[@]}" -o "$out/example"
cc -Wall -Wextra -Werror -std=c11 -I"$inc" crates/hom-capi/c/engine_loop.c "$lib" "${libs[@]}" -o "$out/engine_loop"
"$out/test"
"$out/test_cpp"
"$out/example" 8 # a few frames of a debug build
"$out/engine_loop" 8
