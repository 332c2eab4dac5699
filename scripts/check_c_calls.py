#!/usr/bin/env python3
"""The C library's files call each other in layers: no circle of calls between csrc/*.c.

A file calls another when its object file needs a symbol (``nm``: undefined, ``U``) that the other's
object defines. Calls through the contact-model registry's function pointers (``s->model->setup``,
``->stiffness``, ``->joint``, ...) leave no symbol behind, so they are added as edges too: from every
file whose source calls through ``->model->`` to every file that defines an entry of the registry
(the data symbols that ``solver_contact_model.o`` needs). A model's file must therefore not call the
files that dispatch to it (the stack, the stability limit, the step): what it needs is passed down.

Prints the circles (each as a path of files and the symbols that make its edges) and exits 1 when
there is one; else the layers, bottom first, and exits 0. The objects are compiled with the flags of
csrc/flags.mk (what ships: inlined helpers leave no call), or read from ``--objects DIR``
(``DIR/<file>.o``).

    python scripts/check_c_calls.py                  # compile into a temporary folder
    python scripts/check_c_calls.py --objects build/obj
"""
from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CSRC = ROOT / "csrc"
REGISTRY = "solver_contact_model"
HOOK_CALL = re.compile(r"->model->\w+\s*\(")


def cflags() -> list[str]:
    """The CFLAGS of csrc/flags.mk, as make expands them (check_symbols.sh reads them the same way)."""
    out = subprocess.run(["make", "-s", "-f", "csrc/flags.mk", "-f", "-", "print-cflags"], cwd=ROOT,
                         input="print-cflags: ; @echo $(CFLAGS)\n", capture_output=True, text=True, check=True)
    return out.stdout.split()


def compile_all(sources: list[Path], outdir: Path) -> None:
    cc = os.environ.get("CC", "gcc")
    flags = cflags()
    for src in sources:
        subprocess.run([cc, *flags, f"-I{CSRC}", "-c", str(src), "-o", str(outdir / f"{src.stem}.o")],
                       check=True)


def symbols(obj: Path) -> tuple[set[str], set[str]]:
    """(defined global symbols, undefined symbols) of an object file."""
    out = subprocess.run(["nm", str(obj)], capture_output=True, text=True, check=True).stdout
    defined, undefined = set(), set()
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 2 and parts[0] == "U":
            undefined.add(parts[1])
        elif len(parts) == 3 and parts[1] in "TDRBCGSV":   # global text, data, read-only, bss, common
            defined.add(parts[2])
    return defined, undefined


def call_graph(objdir: Path, sources: list[Path]) -> dict[str, dict[str, set[str]]]:
    """file -> {file it calls: the symbols (or registry hooks) that make the edge}."""
    defs, needs = {}, {}
    for src in sources:
        defs[src.stem], needs[src.stem] = symbols(objdir / f"{src.stem}.o")
    owner = {sym: f for f, syms in defs.items() for sym in syms}
    graph: dict[str, dict[str, set[str]]] = {f: {} for f in defs}
    for f, syms in needs.items():
        for sym in syms:
            g = owner.get(sym)
            if g is not None and g != f:
                graph[f].setdefault(g, set()).add(sym)
    # calls through the registry's function pointers: dispatching file -> every model's file
    models = set(graph.get(REGISTRY, {}))
    for src in sources:
        hooks = sorted(set(m.group(0).split("->")[2].split("(")[0].strip()
                           for m in HOOK_CALL.finditer(src.read_text())))
        if not hooks:
            continue
        for g in models:
            if g != src.stem:
                graph[src.stem].setdefault(g, set()).update(f"model->{h} (registry hook)" for h in hooks)
    return graph


def circles(graph: dict[str, dict[str, set[str]]]) -> list[list[str]]:
    """The strongly connected components of more than one file (Tarjan), each as a list of files."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
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
                out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def one_circle(graph, comp: list[str]) -> list[str]:
    """A shortest path that leaves comp[0] and comes back to it (breadth first)."""
    start = comp[0]
    prev, queue = {start: None}, [start]
    while queue:
        v = queue.pop(0)
        for w in sorted(graph[v]):
            if w == start:
                path = [v]
                while prev[path[-1]] is not None:
                    path.append(prev[path[-1]])
                return path[::-1] + [start]
            if w in comp and w not in prev:
                prev[w] = v
                queue.append(w)
    raise AssertionError(f"{start} is on no circle of {comp}")


def layers(graph) -> list[list[str]]:
    """Files by height: a file's layer is one above the highest file it calls (no circles)."""
    height: dict[str, int] = {}

    def h(v):
        if v not in height:
            height[v] = 1 + max((h(w) for w in graph[v]), default=-1)
        return height[v]

    for v in graph:
        h(v)
    out: list[list[str]] = [[] for _ in range(max(height.values(), default=-1) + 1)]
    for v, k in height.items():
        out[k].append(v)
    return [sorted(x) for x in out]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--objects", type=Path, help="folder holding <file>.o of every csrc/<file>.c")
    args = ap.parse_args(argv)
    sources = sorted(CSRC.glob("*.c"))
    if args.objects is not None:
        graph = call_graph(args.objects, sources)
    else:
        with tempfile.TemporaryDirectory() as tmp:
            compile_all(sources, Path(tmp))
            graph = call_graph(Path(tmp), sources)
    found = circles(graph)
    if found:
        for comp in found:
            print(f"check_c_calls: a circle of calls between {', '.join(f'{c}.c' for c in comp)}")
            print("  for example " + " -> ".join(f"{c}.c" for c in one_circle(graph, comp)) + "; its calls:")
            for a in comp:
                for b in sorted(set(graph[a]) & set(comp)):
                    print(f"    {a}.c -> {b}.c  ({', '.join(sorted(graph[a][b]))})")
        return 1
    print("check_c_calls: no circle of calls between the files of csrc/; layers, bottom first:")
    for k, files in enumerate(layers(graph)):
        print(f"    {k}: {' '.join(files)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
