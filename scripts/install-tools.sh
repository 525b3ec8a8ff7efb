#!/usr/bin/env bash
# Installs the command-line tools hom's CI uses beyond Cargo into a git-ignored
# cache, .cache/tools/ at the repository root, and prints the directory to put
# on PATH. Idempotent: what is already there is kept.
#
#   PATH="$(scripts/install-tools.sh):$PATH"
#
# GNU parallel (Debian's `parallel`, a Perl script) runs the PVS bake's shards
# in CI as a batch system would: fetched with `apt-get download` and unpacked
# with `dpkg -x` (nothing is installed system-wide; no root needed unless the
# package lists are missing). A `parallel` already on PATH is used as it is.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
tools="$root/.cache/tools"
bin="$tools/usr/bin"
mkdir -p "$tools/debs" "$bin"

if ! command -v parallel >/dev/null && [[ ! -x "$bin/parallel" ]]; then
    for cmd in apt-get dpkg perl; do
        if ! command -v "$cmd" >/dev/null; then
            echo "install-tools: '$cmd' is needed to fetch GNU parallel (a Debian/Ubuntu machine)" >&2
            exit 1
        fi
    done
    if ! ls "$tools/debs"/parallel_*.deb >/dev/null 2>&1; then
        if ! (cd "$tools/debs" && apt-get download parallel >&2); then
            echo "install-tools: 'apt-get download parallel' failed; trying 'apt-get update' first" >&2
            apt-get update >&2 || {
                echo "install-tools: 'apt-get update' failed: refreshing package lists needs root" >&2
                exit 1
            }
            (cd "$tools/debs" && apt-get download parallel >&2)
        fi
    fi
    dpkg -x "$(ls "$tools/debs"/parallel_*.deb | head -n 1)" "$tools"
fi
echo "$bin"
