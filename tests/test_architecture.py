"""The architecture map (docs/architecture.md): every file of the C library, the scripts and the
benchmarks, and every package of the Python package, has its line; the packages keep to the layer board
the page draws; and no source comment sends the reader to a document outside the repository.

A newcomer finds a file's or a package's purpose and contracts on the map; one missing from it is one
nobody explained. The check is exact: a file counts as mapped when its path (from the repository root)
appears in a code span of the page, with ``{a,b}`` alternatives expanded (``csrc/rng.{h,c}``); a
package when its folder (``pycolfrag/core/``) or its module's path does.

The layers: the import graph between packages (a package and a top-level module of ``pycolfrag`` each
count as one room), read from the sources with :mod:`ast`, must follow the board's table (a room
imports rooms of its own layer or lower), have no circle, and stay within the sizes the house set:
at most 22 rooms, 90 edges between them and 8 modules at the package's top level.

And the package's sizes: no module over 600 lines, no function over 80 (the house's measure).
"""
from __future__ import annotations

import itertools
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "architecture.md"

# What the map must cover: the library's sources, the package, the scripts and the benchmarks.
COVERED = [("csrc", ("*.c", "*.h")), ("scripts", ("*.py", "*.sh")), ("bench", ("*.py", "*.c", "*.h"))]


def _expand(span: str) -> set[str]:
    """``csrc/rng.{h,c}`` -> {``csrc/rng.h``, ``csrc/rng.c``}; several braces give their product."""
    parts = re.split(r"\{([^{}]*)\}", span)
    choices = [[p] if i % 2 == 0 else p.split(",") for i, p in enumerate(parts)]
    return {"".join(c).strip() for c in itertools.product(*choices)}


# The worked examples name toy files that a walk-through adds and removes again.
EXAMPLES = "## Adding things: worked examples"


def _mapped(until: str | None = None) -> set[str]:
    names: set[str] = set()
    text = DOC.read_text()
    if until is not None:
        text = text.split(until, 1)[0]
    # fenced blocks first: their ``` would pair with the code spans' backticks and shift every span after
    text = re.sub(r"```.*?```", "", text, flags=re.S)
    for span in re.findall(r"`([^`]+)`", text):
        for piece in re.split(r",\s+", span):          # "`a.c`, `b.c`" and "`a.c, b.c`" alike
            names |= _expand(piece)
    return names


def _files() -> list[str]:
    out = []
    for folder, patterns in COVERED:
        for pat in patterns:
            for p in sorted((ROOT / folder).rglob(pat)):
                if "__pycache__" in p.parts or p.name.startswith("_libcolfrag"):
                    continue
                out.append(p.relative_to(ROOT).as_posix())
    return out


def test_every_file_is_on_the_architecture_map():
    names = _mapped()
    missing = [f for f in _files() if f not in names]
    assert not missing, f"files not on docs/architecture.md's map: {missing}"


def test_the_map_names_no_file_that_does_not_exist():
    # A row left behind by a move or a removal misleads as much as a missing one.
    mapped = _mapped(until=EXAMPLES)
    stale = sorted(n for n in mapped
                   if re.fullmatch(r"(csrc|pycolfrag|scripts|bench)/[\w/]+\.(c|h|py|sh)", n) and not (ROOT / n).is_file())
    stale += sorted(n for n in mapped if re.fullmatch(r"pycolfrag/[\w/]+/", n) and not (ROOT / n).is_dir())
    assert not stale, f"docs/architecture.md names files that do not exist: {stale}"


# Documents that live outside the repository (the project's planning files, the tracker).
_OUTSIDE = re.compile(r"\b(SPEC(\.md)?|TOOLCHAIN(\.md)?|STYLE\.md|[Ii]ssue \d+|[Ii]ssues? #\d+)\b")


def test_no_source_comment_cites_a_document_outside_the_repository():
    hits = []
    for f in _files() + [p.relative_to(ROOT).as_posix() for p in (ROOT / "tests").rglob("*.[ch]")] \
            + [p.relative_to(ROOT).as_posix() for p in (ROOT / "tests").glob("*.py")]:
        if f == "tests/test_architecture.py":   # the pattern itself
            continue
        for n, line in enumerate((ROOT / f).read_text(errors="replace").splitlines(), 1):
            if _OUTSIDE.search(line):
                hits.append(f"{f}:{n}: {line.strip()}")
    assert not hits, "cite the reason itself, not an outside document:\n" + "\n".join(hits)


# ---------------------------------------------------------------------------------- sizes
#: The house's measure (docs/architecture.md "Sizes"): a module a reader takes in whole, a
#: function that fits on a screen.
MAX_MODULE_LINES = 600
MAX_FUNCTION_LINES = 80


def _python_sources() -> list[Path]:
    return [p for p in sorted((ROOT / "pycolfrag").rglob("*.py")) if "__pycache__" not in p.parts]


def _long_functions(path: Path, limit: int) -> list[str]:
    """``"path:line name (n lines)"`` of every function or method of ``path`` longer than ``limit`` lines."""
    import ast
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return [f"{path}:{node.lineno} {node.name} ({node.end_lineno - node.lineno + 1} lines)"
            for node in ast.walk(tree) if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
            and node.end_lineno - node.lineno + 1 > limit]


def test_no_module_over_600_lines_and_no_function_over_80():
    """Every module of the package has at most 600 lines and every function or method (from its
    ``def`` to its last line, docstring included) at most 80, counted by ``ast``."""
    big = [f"{p.relative_to(ROOT)} ({len(p.read_text(encoding='utf-8').splitlines())} lines)"
           for p in _python_sources() if len(p.read_text(encoding="utf-8").splitlines()) > MAX_MODULE_LINES]
    assert not big, f"modules over {MAX_MODULE_LINES} lines: {big}"
    long = [f for p in _python_sources() for f in _long_functions(p, MAX_FUNCTION_LINES)]
    assert not long, f"functions over {MAX_FUNCTION_LINES} lines: {long}"


def test_the_size_rule_sees_a_long_method(tmp_path):
    """The counter passes a method of 80 lines and finds one of 81 (the rule's edge, nested in a class)."""
    src = tmp_path / "m.py"
    for n, found in ((80, 0), (81, 1)):
        src.write_text("class C:\n    def f(self):\n" + "        x = 1\n" * (n - 1), encoding="utf-8")
        assert len(_long_functions(src, MAX_FUNCTION_LINES)) == found, n


# ---------------------------------------------------------------------------------- packages and layers
PKG = ROOT / "pycolfrag"
#: The house's sizes for the package graph (docs/architecture.md, "Python package").
MAX_ROOMS, MAX_EDGES, MAX_TOP_LEVEL_MODULES = 22, 90, 8


def _modname(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _graph(pkg: Path = PKG):
    """(rooms, edges): every room of the package (a subpackage, or a module at its top level) and the
    set of rooms each imports, read from every ``import`` of its modules (inside functions too)."""
    import ast
    modules = {_modname(p): p for p in pkg.rglob("*.py") if "__pycache__" not in p.parts}
    packages = {_modname(p) for p in pkg.rglob("__init__.py") if "__pycache__" not in p.parts}

    def room(m: str) -> str:
        if m == "pycolfrag._libcolfrag":          # the C library: the core's one import site loads it
            return "pycolfrag.core"
        parts = m.split(".")
        for i in range(len(parts), 1, -1):
            if ".".join(parts[:i]) in packages:
                return ".".join(parts[:i])
        return m if m in modules else "pycolfrag"

    edges: dict[str, set] = {room(m): set() for m in modules}
    for m, path in modules.items():
        package = m if path.name == "__init__.py" else m.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                mod = ".".join(x for x in ((base if node.level else ""), node.module or "") if x)
                targets = [f"{mod}.{a.name}" if f"{mod}.{a.name}" in modules or a.name == "_libcolfrag" else mod
                           for a in node.names]
            else:
                continue
            for t in targets:
                if t == "pycolfrag" or t.startswith("pycolfrag."):
                    if room(t) != room(m):
                        edges[room(m)].add(room(t))
    return set(edges), edges


def _board() -> list[tuple[str, list[str]]]:
    """The layer board of docs/architecture.md, top first: (layer, [rooms])."""
    text = DOC.read_text().split("## The layers on one board", 1)[1].split("\n## ", 1)[0]
    rows = re.findall(r"^\| ([^|`]+?) \| (`.+`) \|$", text, flags=re.M)
    return [(name, re.findall(r"`([\w.]+)`", cells)) for name, cells in rows]


def _upward(edges, board) -> list[str]:
    level = {r: i for i, (_, rooms) in enumerate(board) for r in rooms}
    return sorted(f"{a} -> {b}" for a, bs in edges.items() for b in bs if level[b] < level[a])


def test_every_package_is_on_the_map_and_the_board_once():
    rooms, _ = _graph()
    names = _mapped()
    unmapped = sorted(r for r in rooms if r != "pycolfrag" and not (
        r.replace(".", "/") + "/" in names or r.replace(".", "/") + ".py" in names))
    assert not unmapped, f"packages without a line on docs/architecture.md's map: {unmapped}"
    on_board = [r for _, rs in _board() for r in rs]
    assert sorted(on_board) == sorted(rooms), (
        f"the board and the package differ: not on the board {sorted(rooms - set(on_board))}, "
        f"not in the package {sorted(set(on_board) - rooms)}, twice {sorted({r for r in on_board if on_board.count(r) > 1})}")


def test_the_packages_import_only_downwards_without_a_circle():
    import graphlib
    rooms, edges = _graph()
    up = _upward(edges, _board())
    assert not up, "imports pointing up the board (docs/architecture.md, 'The layers on one board'):\n" + "\n".join(up)
    tuple(graphlib.TopologicalSorter(edges).static_order())     # raises CycleError on a circle
    n_edges = sum(len(v) for v in edges.values())
    top = [p for p in PKG.glob("*.py")]
    assert len(rooms) <= MAX_ROOMS and n_edges <= MAX_EDGES and len(top) <= MAX_TOP_LEVEL_MODULES, (
        len(rooms), n_edges, len(top))


def test_the_layer_check_finds_an_upward_import_and_a_circle(tmp_path):
    """The graph sees an import inside a function, relative and absolute forms, and the board check
    flags it: a toy package whose bottom room imports its top one, and back."""
    import graphlib
    pkg = tmp_path / "pycolfrag"
    (pkg / "core").mkdir(parents=True)
    (pkg / "__init__.py").write_text("from pycolfrag.core import x\n")
    (pkg / "core" / "__init__.py").write_text("")
    (pkg / "core" / "x.py").write_text("def f():\n    from .. import cli\n")
    (pkg / "cli.py").write_text("from .core import x\n")
    global ROOT
    saved, ROOT = ROOT, tmp_path
    try:
        rooms, edges = _graph(pkg)
    finally:
        ROOT = saved
    assert edges["pycolfrag.core"] == {"pycolfrag.cli"} and edges["pycolfrag.cli"] == {"pycolfrag.core"}
    board = [("top", ["pycolfrag", "pycolfrag.cli"]), ("bottom", ["pycolfrag.core"])]
    assert _upward(edges, board) == ["pycolfrag.core -> pycolfrag.cli"]
    with pytest.raises(graphlib.CycleError):
        tuple(graphlib.TopologicalSorter(edges).static_order())
