"""The architecture map (docs/architecture.md) names every file of the library, the package, the
scripts and the benchmarks, and no source comment sends the reader to a document outside the
repository.

A newcomer finds a file's purpose and contracts on the map; a file missing from it is a file nobody
explained. The check is exact: a file counts as mapped when its path (from the repository root, or
from ``pycolfrag/`` for the package's subpackages, as the map's tables write them) appears in a code
span of the page, with ``{a,b}`` alternatives expanded (``csrc/rng.{h,c}``).

And the package's sizes: no module over 600 lines, no function over 80 (the house's measure).
"""
from __future__ import annotations

import itertools
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "architecture.md"

# What the map must cover: the library's sources, the package, the scripts and the benchmarks.
COVERED = [("csrc", ("*.c", "*.h")), ("pycolfrag", ("*.py",)), ("scripts", ("*.py", "*.sh")),
           ("bench", ("*.py", "*.c", "*.h"))]


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
    missing = [f for f in _files()
               if f not in names and f.removeprefix("pycolfrag/") not in names]
    assert not missing, f"files not on docs/architecture.md's map: {missing}"


def test_the_map_names_no_file_that_does_not_exist():
    # A row left behind by a move or a removal misleads as much as a missing one.
    files = set(_files())
    mapped = _mapped(until=EXAMPLES)
    stale = sorted(n for n in mapped
                   if re.fullmatch(r"(csrc|pycolfrag|scripts|bench)/[\w/]+\.(c|h|py|sh)", n)
                   and n not in files and "pycolfrag/" + n not in files)
    stale += sorted(n for n in mapped
                    if re.fullmatch(r"(ground_motion|analysis)/[\w/]+\.py", n) and "pycolfrag/" + n not in files)
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
