#!/usr/bin/env bash
# Fetches real scenes for hom's tests and benchmarks into a git-ignored cache,
# .cache/scenes/ at the repository root. Idempotent: what is already there is kept.
#
#   scripts/fetch-scenes.sh               everything (OpenArena, Nexuiz, Extreme Tux Racer
#                                         courses, samurai monastery)
#   scripts/fetch-scenes.sh --tests-only  only what `cargo test` uses (openarena-081-maps)
#
# Debian packages are fetched with `apt-get download` and unpacked with `dpkg -x`
# (nothing is installed; no root needed unless the package lists are missing).
# The monastery comes from the pybullet 3.2.7 wheel on PyPI (`pip download`).
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cache="$root/.cache/scenes"
debs="$cache/debs"
mkdir -p "$debs"

tests_only=0
for arg in "$@"; do
    case "$arg" in
        --tests-only) tests_only=1 ;;
        -h|--help) sed -n '2,11p' "$0"; exit 0 ;;
        *) echo "fetch-scenes: unknown option '$arg' (use --tests-only or --help)" >&2; exit 2 ;;
    esac
done

if [[ $tests_only == 1 ]]; then
    packages=(openarena-081-maps)
else
    packages=(openarena-081-maps openarena-088-data openarena-oacmp1 nexuiz-data extremetuxracer-data)
fi

# A package is done when its marker exists (written after a successful dpkg -x).
need_download=()
for p in "${packages[@]}"; do
    [[ -f "$cache/.done-$p" ]] || need_download+=("$p")
done

if ((${#need_download[@]})); then
    if ! command -v apt-get >/dev/null || ! command -v dpkg >/dev/null; then
        echo "fetch-scenes: apt-get and dpkg are needed for ${need_download[*]} (a Debian/Ubuntu machine)" >&2
        exit 1
    fi
    for p in "${need_download[@]}"; do
        if ! ls "$debs/${p}_"*.deb >/dev/null 2>&1; then
            if ! (cd "$debs" && apt-get download "$p"); then
                echo "fetch-scenes: 'apt-get download $p' failed; trying 'apt-get update' first" >&2
                if ! apt-get update; then
                    echo "fetch-scenes: 'apt-get update' failed: refreshing package lists needs root" \
                         "(run 'sudo apt-get update' once, or run this script as root), and Debian's" \
                         "'main' archive must be in the sources (these packages are in bookworm/main)" >&2
                    exit 1
                fi
                (cd "$debs" && apt-get download "$p")
            fi
        fi
        deb=$(ls "$debs/${p}_"*.deb | head -n 1)
        dpkg -x "$deb" "$cache/debian"
        touch "$cache/.done-$p"
        rm -f "$deb" # the unpacked files are what we keep
    done
fi

if [[ $tests_only == 0 && ! -f "$cache/samurai/samurai_monastry.obj" ]]; then
    wheels="$cache/wheels"
    mkdir -p "$wheels" "$cache/samurai"
    if ! ls "$wheels"/pybullet-3.2.7-*.whl >/dev/null 2>&1; then
        # pybullet_data is the same in every wheel; a fixed platform makes the
        # download independent of this machine's Python and architecture.
        python3 -m pip download --no-deps --only-binary=:all: pybullet==3.2.7 \
            --platform manylinux_2_17_x86_64 --python-version 311 -d "$wheels"
    fi
    wheel=$(ls "$wheels"/pybullet-3.2.7-*.whl | head -n 1)
    # Only the monastery's files, not the whole wheel.
    python3 - "$wheel" "$cache/samurai" <<'PY'
import sys, zipfile, os
wheel, out = sys.argv[1], sys.argv[2]
with zipfile.ZipFile(wheel) as z:
    names = [n for n in z.namelist() if os.path.basename(n).startswith("samurai_monastry")]
    if not any(n.endswith(".obj") for n in names):
        sys.exit(f"fetch-scenes: {wheel} holds no samurai_monastry.obj")
    for n in names:
        with z.open(n) as src, open(os.path.join(out, os.path.basename(n)), "wb") as dst:
            dst.write(src.read())
PY
    rm -f "$wheel"
fi

echo "fetch-scenes: cache $cache"
roots=()
for d in debian samurai; do [[ -d "$cache/$d" ]] && roots+=("$d"); done
((${#roots[@]})) && (cd "$cache" && find "${roots[@]}" \( -iname '*.pk3' -o -iname '*.bsp' -o -iname '*.obj' -o -iname '*.mtl' \) \
    -type f -printf '%s\t%p\n' 2>/dev/null | sort -k2 | awk -F'\t' '{ printf "%10.1f MiB  %s\n", $1 / 1048576, $2 }')
du -sh "$cache"
