"""Every import of the package points down, and private names stay in their module (issue 18).

The imports are read from the source (``ast``), module level and inside functions
alike: no module of ``backlash_df`` reaches, directly or through others, a module
that imports it back, and none imports a ``_name`` from another module (a name a
second module needs is public and listed, or lives in a ``_``-prefixed module
meant for sharing).  No file of the repository points to a design file outside it.
"""

import ast
import subprocess

from conftest import ROOT

PACKAGE = ROOT / "backlash_df"


def _modules():
    """Dotted name -> path of every module of the package."""
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        found[".".join(parts)] = path
    return found


def _imports(name, path, modules):
    """``[(imported module, imported name or None)]`` of one module, relative imports resolved."""
    is_package = path.name == "__init__.py"
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [(alias.name, None) for alias in node.names if alias.name.startswith("backlash_df")]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".") if is_package else name.split(".")[:-1]
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            elif node.module and node.module.startswith("backlash_df"):
                target = node.module
            else:
                continue
            for alias in node.names:
                sub = f"{target}.{alias.name}"
                out.append((sub, None) if sub in modules else (target, alias.name))
    return out


def _edges(modules):
    """Module -> set of modules it imports (the package root and its own parents excluded)."""
    edges = {}
    for name, path in modules.items():
        for target, _ in _imports(name, path, modules):
            while target and target not in modules:
                target = target.rpartition(".")[0]
            if target and target != name and target != "backlash_df" and not name.startswith(target + "."):
                edges.setdefault(name, set()).add(target)
    return edges


def _circles(edges):
    """Pairs (a, b) where a reaches b and b reaches a."""
    def reaches(start):
        seen, stack = set(), [start]
        while stack:
            for nxt in edges.get(stack.pop(), ()):
                if nxt not in seen:
                    seen.add(nxt)
                    stack.append(nxt)
        return seen

    reach = {name: reaches(name) for name in edges}
    return sorted({tuple(sorted((a, b))) for a in edges for b in reach[a] if b != a and a in reach.get(b, ())})


def test_no_import_circle():
    modules = _modules()
    assert _circles(_edges(modules)) == []


def test_the_checker_sees_a_circle():
    # the test can fail: a made-up pair of modules importing each other is a circle
    assert _circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [("a", "b"), ("a", "c"), ("b", "c")]


def test_no_module_imports_a_private_name_of_another():
    modules = _modules()
    private = [f"{name} imports {target}.{imported}" for name, path in modules.items()
               for target, imported in _imports(name, path, modules)
               if imported and imported.startswith("_") and not imported.startswith("__") and target != name]
    assert private == []


def test_no_file_points_to_a_design_file_outside_the_repository():
    tracked = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout.split()
    outside = "DESIGN" + ".md"  # the steering notes' file, which the repository does not ship
    citing = [path for path in tracked if path.endswith((".py", ".md", ".ipynb", ".toml", ".txt"))
              and (ROOT / path).exists() and outside in (ROOT / path).read_text(encoding="utf-8", errors="replace")]
    assert citing == []


def test_tests_and_benchmarks_use_public_names():
    """A name a test or a benchmark needs is public (in its module, or in a ``_``-prefixed module meant for it)."""
    modules = _modules()
    private = [f"{path.relative_to(ROOT)} imports {target}.{imported}"
               for folder in ("tests", "benchmarks") for path in sorted((ROOT / folder).rglob("*.py"))
               for target, imported in _imports(f"{folder}.{path.stem}", path, modules)
               if target.startswith("backlash_df") and imported and imported.startswith("_")
               and not imported.startswith("__")]
    assert private == []
