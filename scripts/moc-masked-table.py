#!/usr/bin/env python3
"""hom's masked buffer against Masked Occlusion Culling, from one side-by-side run.

Usage: scripts/moc-masked-table.py RESULTS_DIR

RESULTS_DIR is the folder `../shared/peers/moc/side-by-side.sh .` prints
("results in ..."): it holds hom's `raster.json` (`hom bench raster`, one
raster thread) and MOC's `moc_avx2.json` / `moc_avx512.json`, all measured in
that one run. Prints a Markdown table: per input and resolution, hom's masked
setup + render time, the per-sample z path's, MOC's, their ratios, and the
hidden rectangles each finds (0 wrong "occluded" answers is checked, not
assumed: the columns say how many).
"""

import json
import sys
from pathlib import Path


def load_moc(path):
    if not path.exists():
        return {}
    rows = json.loads(path.read_text())["rows"]
    return {(r["input"], r["width"], r["height"]): r for r in rows}


def fmt(x, spec=".2f"):
    return "" if x is None else format(x, spec)


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__.strip().splitlines()[2])
    root = Path(sys.argv[1])
    try:
        hom = json.loads((root / "raster.json").read_text())["rows"]
    except (OSError, KeyError, ValueError) as e:
        sys.exit(f"moc-masked-table: cannot read {root / 'raster.json'}: {e}")
    avx2 = load_moc(root / "moc_avx2.json")
    avx512 = load_moc(root / "moc_avx512.json")
    print(
        "| input | resolution | masked ms | z ms | MOC AVX2 ms | masked ÷ MOC AVX2 | "
        "MOC AVX-512 ms | masked ÷ MOC AVX-512 | "
        "hidden | masked found | z found | MOC found | wrong occluded masked / z / MOC | "
        "masked query ms | MOC query ms |"
    )
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|")
    for r in hom:
        if r.get("threads") != 1:
            continue
        key = (r["input"], r["width"], r["height"])
        moc = avx2.get(key) or avx512.get(key) or {}
        # Clear + render, as the side-by-side table counts it.
        moc_ms = moc.get("render_ms")
        ratio = r["masked_ms"] / moc_ms if moc_ms else None
        # The yardstick: MOC's AVX-512 code, where this host has it.
        moc512_ms = avx512.get(key, {}).get("render_ms")
        ratio512 = r["masked_ms"] / moc512_ms if moc512_ms else None
        m, z = r.get("masked_queries"), r.get("queries")
        hidden = m["hidden"] if m else None

        def pct(q, key="found"):
            return "–" if not q or not q["hidden"] else f"{100 * q[key] / q['hidden']:.1f} %"

        moc_found = "–"
        if m and m["hidden"]:
            moc_found = f"{100 * m['peer_found'] / m['hidden']:.1f} %"
        wrong = f"{m['wrong_occluded']} / {z['wrong_occluded']} / {m['peer_wrong_occluded']}" if m and z else ""
        print(
            f"| {r['input']} | {r['width']}×{r['height']} | {r['masked_ms']:.2f} | {r['total_ms']:.2f} | "
            f"{fmt(moc_ms)} | {fmt(ratio)} | {fmt(moc512_ms)} | {fmt(ratio512)} | {fmt(hidden, 'd')} | {pct(m)} | {pct(z)} | {moc_found} | {wrong} | "
            f"{fmt(m['ms'] if m else None)} | {fmt(moc.get('rect_ms'))} |"
        )


if __name__ == "__main__":
    main()
