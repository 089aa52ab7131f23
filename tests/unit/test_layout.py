"""The package's plan, enforced: layers that only point down, no import cycle, private
modules behind public names (docs/architecture.md, "Layers").

Every import counts, at module level or inside a function: a cycle through a function-level
import is still a cycle a reader has to untangle. Only imports under ``if TYPE_CHECKING:``
are left out (they never run).
"""

from __future__ import annotations

import ast
import importlib
import inspect
import types
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "src" / "psmat"

# docs/architecture.md, "Layers": lowest first. A top-level part of psmat may import only
# from its own layer or a lower one, and the graph between the parts has no cycle.
LAYERS: list[tuple[str, set[str]]] = [
    ("foundation", {"_core", "_checks", "_atomic", "_filelock", "_cpus", "_progress",
                    "_signals", "_orphans", "_malloc", "_parallel", "_help", "_runners", "_version", "_browser", "_png", "_text", "_folders", "_wallclock", "units",
                    "frames"}),
    ("formats", {"protocol", "io"}),
    ("models", {"circuit", "noise", "iecm", "qzpm", "sensor", "profile"}),
    ("processing", {"process", "balance", "acquire", "spine", "pressure", "regions"}),
    ("world", {"twin", "emulator"}),
    ("synthetic", {"synth"}),
    ("studies", {"study", "posture", "report"}),
    ("applications", {"cli", "__main__", "commands", "live", "workflows", "bench", "experiments", "lab"}),
]
# Edges the ranks alone would allow but the plan forbids: the studies see the simulated
# world only through psmat.synth, so that what processes a study never knows the twin.
FORBIDDEN = {("study", "twin"), ("posture", "twin"), ("report", "twin")}


@dataclass(frozen=True)
class Import:
    source: str   # dotted module that imports
    target: str   # dotted module imported (the module a name comes from)
    name: str     # the name imported from it ("" for `import x`)
    line: int


def modules(package: Path) -> dict[str, tuple[Path, bool]]:
    """Dotted name -> (file, is a package) for every module below ``package``."""
    found: dict[str, tuple[Path, bool]] = {}
    for f in package.rglob("*.py"):
        parts = list(f.relative_to(package.parent).with_suffix("").parts)
        is_pkg = parts[-1] == "__init__"
        found[".".join(parts[:-1] if is_pkg else parts)] = (f, is_pkg)
    for f in package.rglob("*.so"):  # compiled extension modules count as modules too
        parts = list(f.relative_to(package.parent).parts)
        parts[-1] = parts[-1].split(".")[0]
        found[".".join(parts)] = (f, False)
    for f in package.rglob("*.pyi"):  # the compiled extension's stubs name its submodules
        parts = list(f.relative_to(package.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        found.setdefault(".".join(parts), (f, False))
    return found


def _type_checking_blocks(tree: ast.AST) -> set[int]:
    skip: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            for inner in node.body:
                skip |= {id(n) for n in ast.walk(inner)}
    return skip


def imports(package: Path) -> list[Import]:
    """Every import of a module of ``package`` by a module of ``package``."""
    mods = modules(package)
    top = package.name
    found: list[Import] = []
    for mod, (f, is_pkg) in mods.items():
        if f.suffix != ".py":
            continue
        tree = ast.parse(f.read_text(encoding="utf-8"))
        skip = _type_checking_blocks(tree)
        for node in ast.walk(tree):
            if id(node) in skip:
                continue
            if isinstance(node, ast.Import):
                for a in node.names:
                    if a.name == top or a.name.startswith(top + "."):
                        found.append(Import(mod, _known(a.name, mods), "", node.lineno))
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = mod.split(".") if is_pkg else mod.split(".")[:-1]
                    base = base[: len(base) - (node.level - 1)]
                    target = ".".join(base + ([node.module] if node.module else []))
                else:
                    target = node.module or ""
                if not (target == top or target.startswith(top + ".")):
                    continue
                for a in node.names:
                    sub = f"{target}.{a.name}"
                    if sub in mods:
                        found.append(Import(mod, sub, "", node.lineno))
                    else:
                        found.append(Import(mod, _known(target, mods), a.name, node.lineno))
    return found


def _known(name: str, mods: dict[str, tuple[Path, bool]]) -> str:
    while name not in mods and "." in name:
        name = name.rsplit(".", 1)[0]
    return name


def part(module: str) -> str:
    """The top-level part of psmat a module belongs to (``psmat.balance._sway`` -> ``balance``)."""
    bits = module.split(".")
    return bits[1] if len(bits) > 1 else bits[0]


def module_graph(found: list[Import]) -> dict[str, set[str]]:
    """Module -> modules it imports. An import of a module's own parent package is left out:
    a package is initialised before its submodules, which is not a cycle."""
    graph: dict[str, set[str]] = {}
    for imp in found:
        graph.setdefault(imp.source, set())
        graph.setdefault(imp.target, set())
        if imp.target != imp.source and not imp.source.startswith(imp.target + "."):
            graph[imp.source].add(imp.target)
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one node (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(graph.get(w, ())))))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                if len(comp) > 1:
                    found.append(sorted(comp))
    return found


def rank(name: str) -> int:
    for i, (_, members) in enumerate(LAYERS):
        if name in members:
            return i
    raise KeyError(name)


def layer_violations(found: list[Import]) -> list[str]:
    bad = []
    for imp in found:
        a, b = part(imp.source), part(imp.target)
        if a == b or b == "psmat" or a == "psmat":
            continue
        if (a, b) in FORBIDDEN:
            bad.append(f"{imp.source}:{imp.line} imports {imp.target}: {a} must not import {b}")
        elif rank(b) > rank(a):
            bad.append(f"{imp.source}:{imp.line} imports {imp.target}: layer {LAYERS[rank(a)][0]} "
                       f"may not import the higher layer {LAYERS[rank(b)][0]}")
    return bad


def _private(bit: str) -> bool:
    return bit.startswith("_") and not bit.startswith("__")


def privacy_violations(found: list[Import]) -> list[str]:
    """A private name is used only in its module; a private module only inside its package.

    * ``from .x import _helper`` from another module: refused, unless both modules are private
      modules of the same package (a package's private modules work together).
    * ``psmat.balance._sway`` imported from outside ``psmat.balance``: refused. The top-level
      private modules (``psmat._checks``, ...) are the whole package's and serve everyone.
    """
    bad = []
    for imp in found:
        src_pkg = imp.source.rsplit(".", 1)[0]
        tgt_pkg = imp.target.rsplit(".", 1)[0]
        if imp.name and _private(imp.name) and imp.target != imp.source:
            both_private = (_private(imp.source.rsplit(".", 1)[-1]) and _private(imp.target.rsplit(".", 1)[-1])
                            and src_pkg == tgt_pkg)
            if not both_private:
                bad.append(f"{imp.source}:{imp.line} imports the private name {imp.name} of {imp.target}")
        bits = imp.target.split(".")
        for i, bit in enumerate(bits[2:], start=2):  # bits[0] is psmat, bits[1] a top-level part
            if _private(bit):
                owner = ".".join(bits[:i])
                if not (imp.source == owner or imp.source.startswith(owner + ".")):
                    bad.append(f"{imp.source}:{imp.line} reaches into the private module {imp.target}")
                break
    return bad


# -- the checks check themselves on a small tree --------------------------------------------


def _tree(tmp_path: Path, files: dict[str, str]) -> Path:
    pkg = tmp_path / "psmat"
    for rel, text in files.items():
        f = pkg / rel
        f.parent.mkdir(parents=True, exist_ok=True)
        f.write_text(text)
    return pkg


def test_the_checks_find_cycles_layers_and_private_names(tmp_path: Path) -> None:
    pkg = _tree(tmp_path, {
        "__init__.py": "",
        "units.py": "",
        "twin/__init__.py": "from .a import f\n",
        "twin/a.py": "def f():\n    from ..study import g\n",          # function-level, upward
        "study/__init__.py": "from ._b import g\n",
        "study/_b.py": "from ..twin.a import f\n\ndef g():\n    pass\n",  # forbidden edge, and a cycle
        "study/c.py": "from ._b import _hidden\n",                        # private name, public module
        "balance/__init__.py": "from psmat.study._b import g\n",           # private module of another part
        "process/__init__.py": "import psmat.units\nfrom .. import twin\n",
    })
    found = imports(pkg)
    assert cycles(module_graph(found)) == [["psmat.study", "psmat.study._b", "psmat.twin.a"]]
    layers = "\n".join(layer_violations(found))
    assert "psmat.twin.a:2 imports psmat.study" in layers
    assert "study must not import twin" in layers
    assert "psmat.process:2 imports psmat.twin" in layers
    assert "psmat.balance:1 imports psmat.study._b" in layers
    assert "units" not in layers
    private = "\n".join(privacy_violations(found))
    assert "psmat.study.c:1 imports the private name _hidden" in private
    assert "psmat.balance:1 reaches into the private module psmat.study._b" in private
    assert "psmat.study:1" not in private  # a package's own private module is its business


# -- the plan holds for psmat -----------------------------------------------------------------


@pytest.fixture(scope="module")
def psmat_imports() -> list[Import]:
    return imports(PACKAGE)


def test_every_part_of_psmat_has_a_layer() -> None:
    parts = {part(m) for m in modules(PACKAGE)} - {"psmat"}
    unplaced = sorted(p for p in parts if not any(p in members for _, members in LAYERS))
    assert not unplaced, f"give these a layer in LAYERS and docs/architecture.md: {unplaced}"


def test_no_import_cycle_anywhere(psmat_imports: list[Import]) -> None:
    found = cycles(module_graph(psmat_imports))
    assert not found, "import cycles: " + "; ".join(" <-> ".join(c) for c in found)


def test_layers_only_point_down(psmat_imports: list[Import]) -> None:
    bad = layer_violations(psmat_imports)
    assert not bad, "\n".join(bad)


def test_the_parts_of_a_layer_do_not_import_each_other_in_a_circle(psmat_imports: list[Import]) -> None:
    graph: dict[str, set[str]] = {}
    for imp in psmat_imports:
        a, b = part(imp.source), part(imp.target)
        graph.setdefault(a, set())
        graph.setdefault(b, set())
        if a != b and "psmat" not in (a, b):
            graph[a].add(b)
    assert not cycles(graph), cycles(graph)


def test_private_names_and_modules_stay_home(psmat_imports: list[Import]) -> None:
    bad = privacy_violations(psmat_imports)
    assert not bad, "\n".join(bad)


def _public_packages(applications: bool = True) -> list[str]:
    apps = LAYERS[-1][1]
    return sorted(m for m, (f, is_pkg) in modules(PACKAGE).items()
                  if is_pkg and not any(_private(b) for b in m.split("."))
                  and (applications or part(m) not in apps))


@pytest.mark.parametrize("name", _public_packages())
def test_no_public_name_hides_a_module(name: str) -> None:
    """``psmat.balance.sway`` is the function, never also a module the reader must tell apart."""
    pkg = importlib.import_module(name)
    folder = Path(pkg.__file__).parent
    submodules = {p.stem for p in folder.glob("*.py")} | {p.name for p in folder.iterdir() if (p / "__init__.py").exists()}
    hidden = []
    for attr in getattr(pkg, "__all__", []):
        value = getattr(pkg, attr) if hasattr(pkg, attr) else importlib.import_module(f"{name}.{attr}")
        if attr in submodules and not isinstance(value, types.ModuleType):
            hidden.append(f"{name}.{attr} is a {type(value).__name__} and also a module {attr}.py")
    assert not hidden, "; ".join(hidden)


@pytest.mark.parametrize("name", _public_packages(applications=False))
def test_public_modules_of_a_package_are_its_public_names(name: str) -> None:
    """A package with private modules lists what it offers in ``__all__``, and every name
    there exists (a reader looks in one place)."""
    pkg = importlib.import_module(name)
    folder = Path(pkg.__file__).parent
    if not any(_private(p.stem) for p in folder.glob("*.py") if p.stem != "__init__"):
        return
    assert hasattr(pkg, "__all__"), f"{name} has private modules but no __all__"
    missing = [a for a in pkg.__all__ if not hasattr(pkg, a)]
    assert not missing, f"{name}.__all__ names what it lacks: {missing}"
    assert not [a for a in pkg.__all__ if _private(a) and not inspect.ismodule(getattr(pkg, a))]
