#!/usr/bin/env bash
# Bakes a PVS in shards as a batch system would, with GNU parallel standing in
# for it, and checks that `hom pvs merge` gives a file byte-identical to one
# bake. Each shard finds its index in JOB_COMPLETION_INDEX, as in a Kubernetes
# Indexed Job (docs/batch/pvs-bake-job.yaml); the Slurm variant
# (docs/batch/pvs-bake-slurm.sh) is checked by the CLI tests.
#
#   scripts/pvs-shards-check.sh [HOM_BINARY] [SCENE] [SHARDS]
#
# Defaults: target/debug/hom (built first: a no-op when fresh), the built-in
# `spheres` scene with 8 m cells, 4 shards. GNU parallel comes from
# scripts/install-tools.sh.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
hom="${1:-}"
scene="${2:-spheres}"
shards="${3:-4}"
if [[ -z "$hom" ]]; then
    (cd "$root" && cargo build -q -p hom-cli)
    hom="$root/target/debug/hom"
fi
PATH="$("$root/scripts/install-tools.sh"):$PATH"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT

bake=("$hom" pvs bake --scene "$scene" --cell-size 8)
"${bake[@]}" --out "$out/whole.pvs" >/dev/null
# One job per shard, as many at once as there are cores; any failure stops the rest.
export HOM_BIN="$hom" SCENE="$scene" OUT="$out" SHARDS="$shards"
seq 0 $((shards - 1)) | parallel --will-cite --halt now,fail=1 \
    'JOB_COMPLETION_INDEX={} "$HOM_BIN" pvs bake --scene "$SCENE" --cell-size 8 --shard auto/$SHARDS --out "$OUT/shard-{}.pvs" >/dev/null'
"$hom" pvs merge --out "$out/merged.pvs" "$out"/shard-*.pvs >/dev/null
if cmp -s "$out/whole.pvs" "$out/merged.pvs"; then
    echo "pvs-shards-check: $shards shards of $scene, baked with GNU parallel and merged: byte-identical to one bake"
else
    echo "pvs-shards-check: $shards shards of $scene merged differ from one bake" >&2
    exit 1
fi
