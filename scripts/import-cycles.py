#!/usr/bin/env python3
"""Import circles between the files of a crate: prints every strongly
connected set of files (two or more files that import each other, directly
or through others), and exits 1 if there is one.

    scripts/import-cycles.py [--depth N] crates/twinray/src [crates/twinray-cli/src ...]

With `--depth N`, between modules N deep instead of files (`--depth 1`: the
crate's top-level modules, each folder one unit).

A file depends on the file of every module path it names (`use crate::a::b`,
`crate::a::b::f()`, `super::x`, `self::y`), resolved to the deepest module
that has a file of its own; `mod x;` declarations are not dependencies, and
test modules (`#[cfg(test)] mod tests { ... }`) are left out. A name
re-exported by a parent module counts as the parent's: import from the file
that defines it.
"""

import os
import re
import sys


def module_files(src):
    """Module path (tuple) -> file, for every .rs file under `src`."""
    files = {}
    for root, _, names in os.walk(src):
        for name in names:
            if not name.endswith(".rs"):
                continue
            path = os.path.join(root, name)
            rel = os.path.relpath(path, src)[:-3].split(os.sep)
            if rel[-1] in ("mod", "lib", "main"):
                rel = rel[:-1]
            files[tuple(rel)] = path
    return files


def strip_tests(text):
    """The text before a file's `#[cfg(test)] mod NAME {` block."""
    m = re.search(r"#\[cfg\(test\)\]\s*(?:pub(?:\([^)]*\))?\s+)?mod\s+\w+\s*\{", text)
    return text[: m.start()] if m else text


def strip_comments(text):
    """The text without comments, and without visibility paths
    (`pub(in crate::a)` names a module but imports nothing from it)."""
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    text = re.sub(r"//[^\n]*", "", text)
    return re.sub(r"pub\(in [^)]*\)", "pub", text)


def expand_use(tree):
    """`a::{b, c::{d, e}}` -> ['a::b', 'a::c::d', 'a::c::e']."""
    tree = tree.strip()
    depth, start = 0, None
    for i, ch in enumerate(tree):
        if ch == "{" and depth == 0:
            start = i
        depth += ch == "{"
        depth -= ch == "}"
    if start is None:
        return [tree]
    prefix, inner = tree[:start], tree[start + 1 : tree.rindex("}")]
    parts, depth, cur = [], 0, ""
    for ch in inner:
        if ch == "," and depth == 0:
            parts.append(cur)
            cur = ""
            continue
        depth += ch == "{"
        depth -= ch == "}"
        cur += ch
    parts.append(cur)
    out = []
    for p in parts:
        if p.strip():
            out.extend(prefix + q for q in expand_use(p))
    return out


def paths_in(text):
    """Every `crate::`, `super::` or `self::` path the text names."""
    out = []
    for m in re.finditer(r"\buse\s+([^;]+);", text):
        out.extend(expand_use(m.group(1)))
    text = re.sub(r"\buse\s+[^;]+;", "", text)
    out.extend(re.findall(r"\b(?:crate|super|self)(?:::\w+)+", text))
    return [re.sub(r"\s+", "", p).split(" as ")[0] for p in out]


def reexports(files):
    """Per module, the names its file re-exports (`pub use a::B;`) and the
    paths they stand for."""
    out = {}
    for mod, path in files.items():
        with open(path, encoding="utf-8") as f:
            text = strip_comments(strip_tests(f.read()))
        names = {}
        for m in re.finditer(r"\bpub(?:\([^)]*\))?\s+use\s+([^;]+);", text):
            for p in expand_use(m.group(1)):
                p = re.sub(r"\s+", " ", p).strip()
                full, _, alias = p.partition(" as ")
                full = full.replace(" ", "")
                names[(alias or full.split("::")[-1]).strip()] = full
        out[mod] = names
    return out


def resolve(path, here, is_mod_file, files, exports=None, seen=()):
    """The module file a path names, from module `here`; a name a module
    re-exports resolves to the module it comes from."""
    parts = path.split("::")
    if parts[0] == "crate":
        base, parts = (), parts[1:]
    else:
        # `self` is the module itself; `super` its parent (a file that is not
        # a mod.rs is a module of its own, whose parent is its folder's).
        base = here
        while parts and parts[0] in ("self", "super"):
            if parts[0] == "super":
                base = base[:-1]
            parts = parts[1:]
    best = base if base in files else None
    cur = base
    rest = list(parts)
    while rest:
        nxt = cur + (rest[0],)
        if nxt not in files:
            break
        cur = best = nxt
        rest.pop(0)
    if best is not None and rest and exports is not None:
        target = exports.get(best, {}).get(rest[0])
        if target is not None and (best, rest[0]) not in seen:
            again = resolve(target, best, True, files, exports, seen + ((best, rest[0]),))
            if again is not None:
                return again
    return best


def graph(src):
    files = module_files(src)
    exports = reexports(files)
    edges = {m: set() for m in files}
    for mod, path in files.items():
        with open(path, encoding="utf-8") as f:
            text = strip_comments(strip_tests(f.read()))
        is_mod = os.path.basename(path) in ("mod.rs", "lib.rs", "main.rs")
        for p in paths_in(text):
            target = resolve(p, mod, is_mod, files, exports)
            if target is not None and target != mod:
                edges[mod].add(target)
    return files, edges


def cycles(edges):
    """Strongly connected sets of two or more nodes (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]
    sys.setrecursionlimit(10000)

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(comp)

    for v in edges:
        if v not in index:
            visit(v)
    return out


def collapse(files, edges, depth):
    """The graph between modules `depth` deep (1: the crate's top-level
    modules), each standing for its files."""
    unit = {m: m[:depth] for m in files}
    names = {u: os.path.dirname(files[u]) if u in files and files[u].endswith("mod.rs")
             else files.get(u, "/".join(u)) for u in set(unit.values())}
    out = {u: set() for u in names}
    for m, targets in edges.items():
        for t in targets:
            if unit[t] != unit[m]:
                out[unit[m]].add(unit[t])
    return names, out


def main():
    args = sys.argv[1:]
    depth = None
    if args[:1] == ["--depth"]:
        depth, args = int(args[1]), args[2:]
    found = False
    for src in args or ["crates/twinray/src"]:
        files, edges = graph(src)
        if depth is not None:
            files, edges = collapse(files, edges, depth)
        for comp in cycles(edges):
            found = True
            names = sorted(os.path.relpath(files[m], src) for m in comp)
            print(f"{src}: {len(names)} files import each other: {', '.join(names)}")
        if not found:
            print(f"{src}: no import circles ({len(files)} files)")
    sys.exit(1 if found else 0)


if __name__ == "__main__":
    main()
