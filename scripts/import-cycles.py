#!/usr/bin/env python3
"""Import cycles between the source files of each crate (test modules left out).

`scripts/import-cycles.py [CRATES_DIR]` prints one line per cycle (a strongly
connected component of the files' `crate::` / `super::` / `self::` paths, a
name re-exported by a `mod.rs` resolved to the file that defines it) and exits
1 if there is any. Issue 36 broke the seven it found at 5b16e70; keep it at 0.
"""
import re, os, glob, sys
ROOT = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'crates')
def modpath(src, f):
    rel = os.path.relpath(f, src)[:-3].split('/')
    if rel[-1] in ('mod', 'lib'): rel = rel[:-1]
    return tuple(rel)
def strip(s):
    s = re.split(r'#\[cfg\(test\)\]\s*mod tests', s)[0]
    return re.sub(r'(?m)^\s*//.*$', '', s)
found = []
for crate in sorted(glob.glob(ROOT + '/*/src')):
    files = glob.glob(crate + '/**/*.rs', recursive=True)
    mods = {modpath(crate, f): f for f in files}
    text = {m: strip(open(f).read()) for m, f in mods.items()}
    def resolve(here, path):
        parts = path.split('::')
        base = list(here)
        if parts[0] == 'crate': base = []; parts = parts[1:]
        elif parts[0] == 'self': parts = parts[1:]
        else:
            while parts and parts[0] == 'super': base = base[:-1]; parts = parts[1:]
        tgt = tuple(base)
        for i, p in enumerate(parts):
            if tgt + (p,) in mods: tgt = tgt + (p,); continue
            # p is a name in module tgt: follow a re-export `use child::...p`
            for m in re.finditer(r'(?s)\buse\s+([^;]*?);', text.get(tgt, '')):
                u = m.group(1).replace('\n', ' ')
                if re.search(r'\b' + re.escape(p) + r'\b', u):
                    head = re.split(r'::\s*\{', u)[0] if '{' in u else u.rsplit('::', 1)[0]
                    head = head.strip()
                    if head.startswith(('crate', 'super', 'self')):
                        return resolve(tgt, head + '::__')
                    if tgt + (head.split('::')[0],) in mods:
                        return resolve(tgt, 'self::' + head + '::__')
            break
        return tgt
    graph = {m: set() for m in mods}
    for m in mods:
        isdir = os.path.basename(mods[m]) in ('mod.rs', 'lib.rs')
        here = m
        for p in re.findall(r'\b((?:crate|super|self)(?:::\w+)+)', text[m]):
            t = resolve(here, p)
            if t != m and t in mods and t != () and m[:len(t)] != t:
                graph[m].add(t)
    idx, low, st, on, out, n = {}, {}, [], set(), [], [0]
    sys.setrecursionlimit(10000)
    def sc(v):
        idx[v] = low[v] = n[0]; n[0] += 1; st.append(v); on.add(v)
        for w in graph[v]:
            if w not in idx: sc(w); low[v] = min(low[v], low[w])
            elif w in on: low[v] = min(low[v], idx[w])
        if low[v] == idx[v]:
            c = []
            while True:
                w = st.pop(); on.discard(w); c.append(w)
                if w == v: break
            if len(c) > 1: out.append(c)
    for v in graph:
        if v not in idx: sc(v)
    for c in out:
        found.append(c)
        print(crate.split('/')[-2], sorted('/'.join(x) for x in c))
sys.exit(1 if found else 0)
