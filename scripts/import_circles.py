#!/usr/bin/env python3
"""Find import circles between the files of one module of a Rust crate.

Usage: scripts/import_circles.py [--strict] [--tests] [--edges] CRATE_SRC_DIR ...
(e.g. crates/photostereo/src). Exit status 1 when a circle is found.

Every `use` tree and every path written in the code (`super::a::B`, `crate::io::x`,
`model::Model::new`) is resolved item by item to the file that defines the item,
following re-exports (`pub use`) and glob imports, so `crate::lut::Table` counts as a
use of `lut/table/mod.rs`, not of `lut/mod.rs`. Comments and string literals are ignored;
`#[cfg(test)]` items too unless `--tests` is given.

A circle is reported for every module M (a directory module or the crate root) whose
child modules (each child with its whole subtree collapsed into one node) form a
strongly connected component of more than one node: e.g. (before issue 25) `lut/model.rs` ->
`lut/search.rs` -> `lut/model.rs`, or `io` -> `lut` -> `io` at the crate root.
With `--strict`, M's own file (`mod.rs`, `lib.rs`, `search.rs` for `search/`) is a
node too, so a child that uses an item of its parent's file while the parent uses the
child is a circle as well (the usual `use super::Type` of Rust; the strict layering
puts such shared types in a child file of their own).
"""

import os
import re
import sys

ITEM_RE = re.compile(
    r"\b(?:struct|enum|fn|trait|type|const|static|union|mod)\s+(r#)?([A-Za-z_]\w*)"
)
MACRO_RE = re.compile(r"macro_rules!\s*([A-Za-z_]\w*)")
PATH_RE = re.compile(r"(?<![\w:])([A-Za-z_]\w*(?:\s*::\s*[A-Za-z_]\w*)+)")
KEYWORD_STARTS = {"crate", "super", "self"}


def strip_comments_strings(src):
    """Blank out comments, string and char literals (keeping line structure)."""
    out = []
    i, n = 0, len(src)
    while i < n:
        c = src[i]
        if src.startswith("//", i):
            j = src.find("\n", i)
            j = n if j < 0 else j
            i = j
        elif src.startswith("/*", i):
            depth, j = 1, i + 2
            while j < n and depth:
                if src.startswith("/*", j):
                    depth, j = depth + 1, j + 2
                elif src.startswith("*/", j):
                    depth, j = depth - 1, j + 2
                else:
                    j += 1
            out.append("\n" * src.count("\n", i, j))
            i = j
        elif c == "r" and re.match(r'r#*"', src[i:i + 10]) and (i == 0 or not (src[i - 1].isalnum() or src[i - 1] == "_")):
            m = re.match(r'r(#*)"', src[i:])
            end = '"' + m.group(1)
            j = src.find(end, i + len(m.group(0)))
            j = n if j < 0 else j + len(end)
            out.append('""' + "\n" * src.count("\n", i, j))
            i = j
        elif c == '"':
            j = i + 1
            while j < n and src[j] != '"':
                j += 2 if src[j] == "\\" else 1
            out.append('""' + "\n" * src.count("\n", i, j))
            i = j + 1
        elif c == "'":
            m = re.match(r"'(\\.|\\u\{[0-9a-fA-F]+\}|\\x..|[^\\'])'", src[i:])
            if m:
                out.append("' '")
                i += len(m.group(0))
            else:  # a lifetime
                out.append(c)
                i += 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def matching_brace(s, i):
    depth = 0
    for j in range(i, len(s)):
        if s[j] == "{":
            depth += 1
        elif s[j] == "}":
            depth -= 1
            if depth == 0:
                return j
    return len(s) - 1


def strip_cfg_test(code):
    """Remove items under #[cfg(test)] (a block item or a single `;` item)."""
    while True:
        m = re.search(r"#\s*\[\s*cfg\s*\(\s*test\s*\)\s*\]", code)
        if not m:
            return code
        k = m.end()
        brace, semi = code.find("{", k), code.find(";", k)
        if semi >= 0 and (brace < 0 or semi < brace):
            end = semi
        else:
            end = matching_brace(code, brace)
        code = code[: m.start()] + "\n" * code.count("\n", m.start(), end + 1) + code[end + 1:]


def split_top(s, sep=","):
    parts, depth, cur = [], 0, []
    for ch in s:
        if ch == "{":
            depth += 1
        elif ch == "}":
            depth -= 1
        if ch == sep and depth == 0:
            parts.append("".join(cur))
            cur = []
        else:
            cur.append(ch)
    parts.append("".join(cur))
    return [p.strip() for p in parts if p.strip()]


def expand_use_tree(tree, prefix):
    """Yield (local name or '*', path segments) for a use tree."""
    tree = re.sub(r"\s+", " ", tree).strip()
    if tree.startswith("::"):
        tree = tree[2:]
    if "{" in tree and (tree.find("{") < tree.find(" as ") if " as " in tree else True):
        head = tree[: tree.find("{")].rstrip(":").strip()
        inner = tree[tree.find("{") + 1: tree.rfind("}")]
        base = prefix + [s.strip() for s in head.split("::") if s.strip()]
        for part in split_top(inner):
            yield from expand_use_tree(part, base)
        return
    alias = None
    if " as " in tree:
        tree, alias = [x.strip() for x in tree.split(" as ", 1)]
    segs = prefix + [s.strip() for s in tree.split("::") if s.strip()]
    if segs[-1] == "*":
        yield "*", segs[:-1]
    elif segs[-1] == "self":
        yield alias or segs[-2], segs[:-1]
    else:
        yield alias or segs[-1], segs


class Module:
    def __init__(self, path, file):
        self.path = path  # tuple of segments below the crate root
        self.file = file
        self.children = {}
        self.defs = set()
        self.imports = {}  # local name -> absolute segments (resolved lazily)
        self.globs = []
        self.paths = []  # (segments) written in code, relative
        self.raw_imports = []


def find_child_file(dirpath, stem, name):
    """The file of child `name` of a module whose file is dirpath/stem.rs (or mod.rs)."""
    for cand in (os.path.join(dirpath, name + ".rs"), os.path.join(dirpath, name, "mod.rs")):
        if os.path.exists(cand):
            return cand
    return None


def load(src_dir, with_tests):
    modules = {}

    def visit(path, file):
        mod = Module(path, file)
        modules[path] = mod
        code = strip_comments_strings(open(file, encoding="utf-8").read())
        if not with_tests:
            code = strip_cfg_test(code)
        # child modules: `mod x;` (file) ; inline `mod x {` stays part of this file
        base = os.path.basename(file)
        if base in ("mod.rs", "lib.rs", "main.rs"):
            sub = os.path.dirname(file)
        else:
            sub = os.path.join(os.path.dirname(file), base[:-3])
        for m in re.finditer(r"\bmod\s+([A-Za-z_]\w*)\s*;", code):
            name = m.group(1)
            child = find_child_file(sub, None, name)
            if child:
                mod.children[name] = path + (name,)
                visit(path + (name,), child)
        mod.defs = {m.group(2) for m in ITEM_RE.finditer(code)} | {
            m.group(1) for m in MACRO_RE.finditer(code)
        }
        for m in re.finditer(r"\buse\s+([^;]+);", code):
            for name, segs in expand_use_tree(m.group(1), []):
                mod.raw_imports.append((name, segs))
        code_wo_use = re.sub(r"\buse\s+[^;]+;", "", code)
        for m in PATH_RE.finditer(code_wo_use):
            segs = [s.strip() for s in m.group(1).split("::")]
            mod.paths.append(segs)
        return mod

    root_file = os.path.join(src_dir, "lib.rs")
    if not os.path.exists(root_file):
        root_file = os.path.join(src_dir, "main.rs")
    visit((), root_file)
    return modules


class Resolver:
    def __init__(self, modules):
        self.modules = modules

    def absolute(self, mod, segs):
        """Turn segments written in `mod` into (start module path, remaining segs) or None."""
        if not segs:
            return None
        first = segs[0]
        if first == "crate":
            return (), segs[1:]
        if first == "self":
            return mod.path, segs[1:]
        if first == "super":
            p = mod.path
            i = 0
            while i < len(segs) and segs[i] == "super":
                p = p[:-1]
                i += 1
            return p, segs[i:]
        return mod.path, segs  # a name looked up in `mod`'s scope

    def lookup(self, modpath, segs, depth=0, seen=None):
        """The module path of the file defining the item `segs` seen from modpath."""
        if depth > 40:
            return None
        seen = seen or set()
        mod = self.modules.get(modpath)
        if mod is None:
            return None
        if not segs:
            return modpath
        name, rest = segs[0], segs[1:]
        if name in mod.children:
            return self.lookup(mod.children[name], rest, depth + 1, seen)
        if name in mod.defs:
            return modpath
        key = (modpath, name)
        if key in seen:
            return None
        seen.add(key)
        for lname, isegs in mod.raw_imports:
            if lname == name:
                start = self.absolute(mod, isegs)
                if start is None:
                    continue
                got = self.lookup(start[0], start[1] + rest, depth + 1, seen)
                if got is not None:
                    return got
        for lname, isegs in mod.raw_imports:
            if lname == "*":
                start = self.absolute(mod, isegs)
                if start is None:
                    continue
                got = self.lookup(start[0], start[1] + segs, depth + 1, seen)
                if got is not None:
                    return got
        return None

    def resolve(self, mod, segs):
        if segs[0] in ("Self", "std", "core", "alloc"):
            return None
        start = self.absolute(mod, segs)
        if start is None:
            return None
        if segs[0] not in KEYWORD_STARTS:
            # a bare first segment must be a name of this file's scope
            if not (
                segs[0] in mod.children
                or segs[0] in mod.defs
                or any(n == segs[0] for n, _ in mod.raw_imports)
            ):
                return None
        return self.lookup(start[0], start[1])


def file_edges(modules):
    r = Resolver(modules)
    edges = {}
    for path, mod in modules.items():
        targets = set()
        for _, segs in mod.raw_imports:
            if segs and segs[0] in KEYWORD_STARTS:
                t = r.resolve(mod, segs)
                if t is not None:
                    targets.add(t)
        for segs in mod.paths:
            t = r.resolve(mod, segs)
            if t is not None:
                targets.add(t)
        targets.discard(path)
        edges[path] = targets
    return edges


def sccs(nodes, adj):
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def strong(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in adj.get(v, ()):
            if w not in index:
                strong(w)
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
            out.append(comp)

    sys.setrecursionlimit(10000)
    for v in nodes:
        if v not in index:
            strong(v)
    return out


def circles(modules, edges, strict):
    found = []
    for mpath, mod in modules.items():
        if not mod.children:
            continue
        own = mpath + ("<self>",)

        def node(p):
            if p == mpath:
                return own if strict else None
            if p[: len(mpath)] == mpath and len(p) > len(mpath):
                return mpath + (p[len(mpath)],)
            return None

        adj = {}
        for src, dsts in edges.items():
            a = node(src)
            if a is None:
                continue
            for d in dsts:
                b = node(d)
                if b is not None and b != a:
                    adj.setdefault(a, set()).add(b)
        nodes = ([own] if strict else []) + [mpath + (c,) for c in mod.children]
        for comp in sccs(nodes, adj):
            if len(comp) > 1:
                found.append((mpath, sorted(comp), adj))
    return found


def name(p):
    if p and p[-1] == "<self>":
        return "::".join(("crate",) + p[:-1]) + " (own file)"
    return "::".join(("crate",) + p)


def main(argv):
    with_tests = "--tests" in argv
    show_edges = "--edges" in argv
    strict = "--strict" in argv
    dirs = [a for a in argv if not a.startswith("--")]
    total = 0
    for d in dirs:
        modules = load(d, with_tests)
        edges = file_edges(modules)
        if show_edges:
            for src in sorted(edges):
                for dst in sorted(edges[src]):
                    print(f"{d}: {name(src)} -> {name(dst)}")
        found = circles(modules, edges, strict)
        for mpath, comp, adj in found:
            members = set(comp)
            print(f"{d}: circle in {name(mpath)}: " + ", ".join(name(c) for c in comp))
            for a in comp:
                for b in sorted(adj.get(a, ())):
                    if b in members:
                        print(f"    {name(a)} -> {name(b)}")
        mode = "strict" if strict else "between child modules"
        print(f"{d}: {len(modules)} files, {len(found)} circle(s) ({mode})")
        total += len(found)
    return 1 if total else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
