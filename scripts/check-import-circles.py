#!/usr/bin/env python3
"""File-level import circles inside each crate of the workspace.

A file A depends on a file B of the same crate when A names an item that B defines:
through a `use` path (`use crate::b::Item;`, `use super::{x, y::z};`, `use super::*;`
for the names A then uses) or a path in code (`crate::b::f()`, `super::b::Item`,
`child::f()`). Paths are resolved the way rustc resolves them: `mod` declarations give
the module tree (`x.rs` or `x/mod.rs`, nested folders, inline `mod x { .. }`,
`#[path = ".."]`), `pub use` re-exports are followed to the file that defines the item
(a facade such as lib.rs re-exporting `x::Item` is no dependency of its own), and glob
imports count only the names the importing file uses. Declaring `mod x;` is not a use.
Not seen: method calls on a type whose `impl` block lives in another file (that needs
type inference) and macros used by textual scope; comments and strings are ignored.

A circle is a strongly connected set of two or more files; each is printed with one
shortest cycle through it and, for every step, the first line that makes it.

    scripts/check-import-circles.py [--skip-tests] [CRATE_DIR ...]

With no CRATE_DIR it checks every crates/*/ of the workspace (the library and, where
there is one, the binary). `--skip-tests` leaves out `#[cfg(test)]` modules. Exits 1
when a circle is found, else 0.
"""

import argparse
import re
import sys
from collections import defaultdict
from pathlib import Path

IDENT = r"[A-Za-z_][A-Za-z0-9_]*"
ITEM_RE = re.compile(
    r"\b(?:fn|struct|enum|trait|type|const|static|union)\s+(" + IDENT + r")"
    r"|\bmacro_rules!\s*(" + IDENT + r")"
)
KEYWORDS = {"crate", "super", "self", "Self"}


def strip(text):
    """The source with comments, strings and char literals blanked (newlines kept)."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            depth, j = 1, i + 2
            while j < n and depth:
                if text.startswith("/*", j):
                    depth, j = depth + 1, j + 2
                elif text.startswith("*/", j):
                    depth, j = depth - 1, j + 2
                else:
                    j += 1
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif (m := re.match(r'b?r(#*)"', text[i:i + 260])) and (
            i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")
        ):
            end = '"' + m.group(1)
            j = text.find(end, i + m.end())
            j = n if j < 0 else j + len(end)
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            j = min(j + 1, n)
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == "'":
            # A char literal ('a', '\n', '\u{1F600}'); a lifetime ('a) is left alone.
            m = re.match(r"'(\\u\{[0-9a-fA-F]+\}|\\.|[^\\'])'", text[i:i + 12])
            if m:
                out.append(" " * m.end())
                i += m.end()
            else:
                out.append(c)
                i += 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def line_of(text, pos):
    return text.count("\n", 0, pos) + 1


class Module:
    def __init__(self, name, path, file, parent, is_test):
        self.name = name
        self.path = path  # segments from the crate root
        self.file = file
        self.parent = parent
        self.children = {}
        self.items = set()
        # alias -> (segments, is_pub, line, is_test); globs: (segments, line, is_test)
        self.aliases = {}
        self.globs = []
        # (segments, line, is_test) of paths written in code
        self.code_paths = []
        # identifiers of code outside `use` items: name -> (first line, is_test)
        self.idents = {}
        self.is_test = is_test


def parse_use_tree(s):
    """`a::b::{c, d as e, f::*}` -> [(segments, alias or None, is_glob)]."""
    tokens = re.findall(IDENT + r"|::|[{},*]", s)
    out = []
    pos = 0

    def peek():
        return tokens[pos] if pos < len(tokens) else None

    def tree(prefix):
        # tree := path ( "::" ( "{" tree ("," tree)* "}" | "*" ) | "as" IDENT )?
        nonlocal pos
        segs = list(prefix)
        while True:
            t = peek()
            if t == "{":
                pos += 1
                while peek() not in ("}", None):
                    if peek() == ",":
                        pos += 1
                        continue
                    tree(segs)
                pos += 1
                return
            if t == "*":
                pos += 1
                out.append((segs, None, True))
                return
            if t == "::":
                pos += 1
                continue
            if t is None or t in (",", "}"):
                break
            if t == "as" and len(segs) > len(prefix):
                pos += 2
                alias = tokens[pos - 1]
                out.append((segs[:-1] if segs[-1] == "self" else segs, alias, False))
                return
            segs.append(t)
            pos += 1
        if segs and segs[-1] == "self":
            segs = segs[:-1]
        if len(segs) > len(prefix) or segs:
            out.append((segs, None, False))

    while pos < len(tokens):
        if peek() == ",":
            pos += 1
            continue
        tree([])
    return out


class Crate:
    def __init__(self, root_file, label):
        self.label = label
        self.files = {}
        self.root = self.load(root_file, None, "crate", [], False, mod_rs=True)

    def load(self, file, parent, name, path, is_test, mod_rs):
        raw = file.read_text(encoding="utf-8")
        text = strip(raw)
        self.files[file] = text
        module = Module(name, path, file, parent, is_test)
        self.scan(text, module, file, mod_rs)
        return module

    def child_file(self, file, mod_rs, name, path_attr):
        base = file.parent if mod_rs else file.parent / file.stem
        if path_attr:
            p = file.parent / path_attr
            return (p, p.name == "mod.rs")
        for cand, is_mod in ((base / f"{name}.rs", False), (base / name / "mod.rs", True)):
            if cand.exists():
                return (cand, is_mod)
        return (None, False)

    def scan(self, text, top, file, mod_rs):
        """Splits `text` into module scopes (inline `mod x { .. }`), declares child
        modules, records items, uses and code paths per scope."""
        tokens = re.finditer(
            r"(?P<attr>#!?\[)|(?P<mod>\bmod\s+(?P<modname>" + IDENT + r")\s*(?P<modend>[;{]))"
            r"|(?P<use>\b(?:pub(?:\s*\([^)]*\))?\s+)?use\s+(?P<usebody>[^;]*);)"
            r"|(?P<open>\{)|(?P<close>\})",
            text,
        )
        stack = [(top, 0)]  # (module, brace depth where its body starts)
        depth = 0
        pending_attrs = []  # attribute texts before the next item
        use_spans = []
        last_end = 0
        for m in tokens:
            module, base = stack[-1]
            if m.group("attr"):
                # The attribute's full text up to its matching bracket.
                j, d = m.end(), 1
                while j < len(text) and d:
                    if text[j] == "[":
                        d += 1
                    elif text[j] == "]":
                        d -= 1
                    j += 1
                attr = text[m.start():j]
                # Attributes' string values were blanked; read #[path] from the raw file.
                pending_attrs.append((m.start(), j, attr))
                continue
            if m.group("mod"):
                name = m.group("modname")
                attrs = self.attrs_before(text, m.start(), pending_attrs)
                is_test = module.is_test or any(re.search(r"cfg\s*\(\s*test\s*\)", a) for _, _, a in attrs)
                path_attr = None
                for a_start, a_end, a in attrs:
                    if re.match(r"#\[\s*path\b", a):
                        raw = file.read_text(encoding="utf-8")[a_start:a_end]
                        pm = re.search(r'"([^"]+)"', raw)
                        path_attr = pm.group(1) if pm else None
                if m.group("modend") == ";":
                    cf, is_mod = self.child_file(file, mod_rs if module is top else False, name, path_attr)
                    if module is not top:
                        # A file module inside an inline one: its folder is nested.
                        rel = "/".join(module.path[len(top.path):])
                        base_dir = (file.parent if mod_rs else file.parent / file.stem) / rel
                        cf = None
                        for cand, im in ((base_dir / f"{name}.rs", False), (base_dir / name / "mod.rs", True)):
                            if cand.exists():
                                cf, is_mod = cand, im
                                break
                    if cf is not None:
                        child = self.load(cf, module, name, module.path + [name], is_test, is_mod)
                        module.children[name] = child
                    else:
                        print(f"warning: {file}: no file for `mod {name};`", file=sys.stderr)
                    module.items.add(name)
                else:
                    child = Module(name, module.path + [name], file, module, is_test)
                    module.children[name] = child
                    module.items.add(name)
                    depth += 1
                    stack.append((child, depth))
                pending_attrs = []
                continue
            if m.group("use"):
                line = line_of(text, m.start())
                is_pub = m.group(0).lstrip().startswith("pub")
                for segs, alias, is_glob in parse_use_tree(m.group("usebody")):
                    if not segs:
                        continue
                    if is_glob:
                        module.globs.append((segs, line, module.is_test, depth == base))
                    else:
                        name = alias or segs[-1]
                        if name == "_":
                            name = "_" + "::".join(segs)
                        if name in module.aliases:
                            name = name + "#" + str(line)
                        module.aliases[name] = (segs, is_pub and depth == base, line, module.is_test)
                use_spans.append((m.start(), m.end()))
                pending_attrs = []
                continue
            if m.group("open"):
                depth += 1
                continue
            if m.group("close"):
                if len(stack) > 1 and depth == stack[-1][1]:
                    stack.pop()
                depth -= 1
                continue
        # Second pass: items at module level, identifiers and code paths, per scope.
        self.scan_code(text, top, use_spans)

    @staticmethod
    def attrs_before(text, pos, attrs):
        """The attributes directly before `pos` (only whitespace, other attributes or a
        visibility between them)."""
        out = []
        cur = pos
        for a in reversed(attrs):
            gap = text[a[1]:cur]
            if re.fullmatch(r"\s*(pub(\s*\([^)]*\))?)?\s*", gap):
                out.append(a)
                cur = a[0]
            else:
                break
        return out

    def scan_code(self, text, top, use_spans):
        # Re-walk braces to attribute each position to its scope.
        scopes = []  # (start, end, module, base depth)

        def collect(module):
            for c in module.children.values():
                if c.file == top.file:
                    collect(c)
            scopes.append(module)

        # Positions of inline modules' bodies.
        spans = {}
        stack = [(top, 0)]
        depth = 0
        for m in re.finditer(r"\bmod\s+(" + IDENT + r")\s*\{|\{|\}", text):
            if m.group(0).startswith("mod"):
                module = stack[-1][0]
                child = module.children.get(m.group(1))
                depth += 1
                if child is not None and child.file == top.file:
                    stack.append((child, depth))
                    spans.setdefault(child, []).append([m.end(), None, depth])
            elif m.group(0) == "{":
                depth += 1
            else:
                if len(stack) > 1 and depth == stack[-1][1]:
                    spans[stack[-1][0]][-1][1] = m.start()
                    stack.pop()
                depth -= 1

        # `use` items and `mod x;` declarations name no item of their own.
        use_mask = bytearray(len(text))
        for a, b in use_spans:
            use_mask[a:b] = b"\x01" * (b - a)
        for m in re.finditer(r"\bmod\s+" + IDENT, text):
            use_mask[m.start():m.end()] = b"\x01" * (m.end() - m.start())

        def module_at(pos):
            best, best_start = top, -1
            for mod, ranges in spans.items():
                for a, b, _ in ranges:
                    if a <= pos < (b if b is not None else len(text)) and a > best_start:
                        best, best_start = mod, a
            return best

        # Item definitions at module level: brace depth equals the scope's base.
        depth_at = []
        d = 0
        for m in re.finditer(r"[{}]", text):
            depth_at.append((m.start(), d))
            d += 1 if m.group(0) == "{" else -1

        def depth_of(pos):
            lo, hi, dd = 0, len(depth_at), 0
            while lo < hi:
                mid = (lo + hi) // 2
                if depth_at[mid][0] < pos:
                    lo = mid + 1
                else:
                    hi = mid
            if lo == 0:
                return 0
            p, dd = depth_at[lo - 1]
            return dd + (1 if text[p] == "{" else -1)

        def base_of(mod):
            for a, b, dpt in spans.get(mod, []):
                return dpt
            return 0

        for m in ITEM_RE.finditer(text):
            name = m.group(1) or m.group(2)
            mod = module_at(m.start())
            if depth_of(m.start()) == base_of(mod):
                mod.items.add(name)
        for m in re.finditer(r"(?<![A-Za-z0-9_:$])(" + IDENT + r"(?:\s*::\s*" + IDENT + r")*)", text):
            if use_mask[m.start()]:
                continue
            mod = module_at(m.start())
            segs = [s.strip() for s in m.group(1).split("::")]
            line = line_of(text, m.start())
            if segs[0] not in mod.idents:
                mod.idents[segs[0]] = (line, mod.is_test)
            elif mod.idents[segs[0]][1] and not mod.is_test:
                mod.idents[segs[0]] = (line, False)
            if len(segs) > 1:
                mod.code_paths.append((segs, line, mod.is_test))


class Resolver:
    def __init__(self, crate):
        self.crate = crate

    def start(self, module, seg):
        """The module or (module, item) the first segment of a path names in `module`."""
        if seg == "crate":
            return ("mod", self.crate.root)
        if seg == "super":
            return ("mod", module.parent) if module.parent else None
        if seg == "self":
            return ("mod", module)
        if seg in module.children:
            return ("mod", module.children[seg])
        return None

    def resolve(self, module, segs, seen=None):
        """The file that defines what `segs` (written in `module`) names, or a module
        when the path ends at one; None for paths outside the crate."""
        seen = seen or set()
        key = (id(module), tuple(segs))
        if key in seen:
            return None
        seen.add(key)
        first = self.start(module, segs[0])
        rest = segs[1:]
        if first is None:
            alias = module.aliases.get(segs[0])
            if alias is not None:
                return self.resolve(module, alias[0] + rest, seen)
            if segs[0] in module.items:
                return ("file", module.file)
            for gsegs, *_ in module.globs:
                target = self.resolve(module, gsegs, seen)
                if target and target[0] == "mod":
                    r = self.resolve_in(target[1], [segs[0]] + rest, seen, strict=True)
                    if r:
                        return r
            return None
        cur = first[1]
        return self.resolve_in(cur, rest, seen) if rest else ("mod", cur)

    def resolve_in(self, cur, rest, seen, strict=False):
        for i, seg in enumerate(rest):
            if seg == "super":
                if cur.parent is None:
                    return None
                cur = cur.parent
                continue
            if seg == "self":
                continue
            if seg in cur.children:
                cur = cur.children[seg]
                continue
            if seg in cur.items:
                return ("file", cur.file)
            alias = cur.aliases.get(seg)
            if alias is not None:
                return self.resolve(cur, alias[0] + rest[i + 1:], seen)
            for gsegs, *_ in cur.globs:
                target = self.resolve(cur, gsegs, seen)
                if target and target[0] == "mod":
                    r = self.resolve_in(target[1], rest[i:], seen, strict=True)
                    if r:
                        return r
            return None if strict else ("file", cur.file)
        return ("mod", cur)

    def visible_names(self, mod):
        return set(mod.items) | set(mod.children) | {a.split("#")[0] for a in mod.aliases}


def modules_of(module):
    yield module
    for c in module.children.values():
        yield from modules_of(c)


def edges_of(crate, skip_tests):
    """file -> {file: (line, evidence)}"""
    res = Resolver(crate)
    edges = defaultdict(dict)

    def add(src_mod, target, line, what, is_test):
        if target is None or (skip_tests and is_test):
            return
        kind, obj = target
        dst = obj if kind == "file" else obj.file
        if kind == "mod":
            return  # naming a module is no use of its file's items
        src = src_mod.file
        if dst == src:
            return
        prev = edges[src].get(dst)
        # The first line that makes the step, code outside tests before test code.
        if prev is None or (is_test, line) < (prev[2], prev[0]):
            edges[src][dst] = (line, what, is_test)

    for mod in modules_of(crate.root):
        if skip_tests and mod.is_test:
            continue
        for name, (segs, is_pub, line, is_test) in mod.aliases.items():
            base = name.split("#")[0]
            target = res.resolve(mod, segs)
            if target is None or target[0] == "mod":
                continue
            used = mod.idents.get(base)
            if used is None:
                continue  # a re-export only: references are followed through it
            add(mod, target, line, "use " + "::".join(segs), is_test)
        for segs, line, is_test, _top in mod.globs:
            target = res.resolve(mod, segs)
            if not target or target[0] != "mod":
                continue
            for ident, (uline, utest) in mod.idents.items():
                if ident in KEYWORDS:
                    continue
                if ident in mod.items or ident in mod.children or ident in mod.aliases:
                    continue
                r = res.resolve_in(target[1], [ident], set(), strict=True)
                if r and r[0] == "file":
                    add(mod, r, uline, "use " + "::".join(segs) + "::* (" + ident + ")", is_test or utest)
        for segs, line, is_test in mod.code_paths:
            head = segs[0]
            if not (head in KEYWORDS - {"Self"} or head in mod.children or head in mod.aliases):
                continue
            if head == "Self":
                continue
            target = res.resolve(mod, segs)
            add(mod, target, line, "::".join(segs), is_test)
    return edges


def sccs(nodes, edges):
    index, low, on, stack, out = {}, {}, set(), [], []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges.get(v, {}):
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
            out.append(comp)

    sys.setrecursionlimit(10000)
    for v in nodes:
        if v not in index:
            visit(v)
    return [c for c in out if len(c) > 1]


def shortest_cycle(comp, edges, start):
    """A shortest cycle through `start` inside `comp` (breadth first)."""
    comp = set(comp)
    prev = {start: None}
    queue = [start]
    while queue:
        nxt = []
        for v in queue:
            for w in sorted(edges.get(v, {})):
                if w not in comp:
                    continue
                if w == start:
                    path = [v]
                    while prev[path[-1]] is not None:
                        path.append(prev[path[-1]])
                    return list(reversed(path))
                if w not in prev:
                    prev[w] = v
                    nxt.append(w)
        queue = nxt
    return [start]


def check(root_file, label, skip_tests, workspace):
    crate = Crate(root_file, label)
    edges = edges_of(crate, skip_tests)
    comps = sccs(sorted(crate.files), edges)
    rel = lambda p: str(p.relative_to(workspace)) if p.is_relative_to(workspace) else str(p)
    reported = []
    for comp in sorted(comps, key=lambda c: sorted(c)[0]):
        comp = sorted(comp)
        # Every 2-cycle in the set, then one shortest cycle through each file not in one.
        pairs = [(a, b) for a in comp for b in comp if a < b and b in edges.get(a, {}) and a in edges.get(b, {})]
        covered = {x for p in pairs for x in p}
        cycles = [[a, b] for a, b in pairs]
        for f in comp:
            if f not in covered:
                cyc = shortest_cycle(comp, edges, f)
                if len(cyc) > 1 and not any(set(cyc) == set(c) for c in cycles):
                    cycles.append(cyc)
                    covered |= set(cyc)
        lines = []
        for cyc in cycles:
            names = " -> ".join(rel(f) for f in cyc + [cyc[0]])
            lines.append("  circle: " + names)
            for a, b in zip(cyc, cyc[1:] + [cyc[0]]):
                line, what, is_test = edges[a][b]
                tag = " (test code only)" if is_test else ""
                lines.append(f"    {rel(a)}:{line} names {rel(b)}: {what}{tag}")
        reported.append((comp, lines))
    return reported


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--skip-tests", action="store_true", help="leave out #[cfg(test)] modules")
    ap.add_argument("crates", nargs="*", type=Path, help="crate folders (default: crates/*)")
    args = ap.parse_args()
    workspace = Path(__file__).resolve().parent.parent
    dirs = args.crates or sorted(p for p in (workspace / "crates").iterdir() if p.is_dir())
    found = 0
    for d in dirs:
        d = d.resolve()
        for root in ("lib.rs", "main.rs"):
            f = d / "src" / root
            if not f.exists():
                continue
            label = d.name + ("" if root == "lib.rs" else " (bin)")
            reported = check(f, label, args.skip_tests, workspace)
            if not reported:
                print(f"{label}: no circles")
                continue
            found += len(reported)
            print(f"{label}: {len(reported)} circle(s)")
            for _, lines in reported:
                print("\n".join(lines))
    sys.exit(1 if found else 0)


if __name__ == "__main__":
    main()
