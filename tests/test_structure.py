"""Every import of the package points down, and private names stay in their module (issues 18, 45).

The imports are read from the source (``ast``), module level and inside functions
alike: no module of ``backlash_df`` reaches, directly or through others, a module
that imports it back, and none imports a ``_name`` from another module (a name a
second module needs is public and listed, or lives in a ``_``-prefixed module
meant for sharing).  What a ``_`` module shares stays out of the public API: no
public module lists in its ``__all__`` a name that comes from a ``_`` module of
another package (a package's public modules may list its own ``_`` modules' names,
as ``scipy.optimize`` lists those of ``scipy.optimize._minimize``).  No file of the
repository points to a design file outside it.
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


def _source_module(name, is_package, node):
    """The module a ``from ... import`` of module ``name`` reads from, relative levels resolved; None outside
    the package."""
    if node.level:
        base = name.split(".") if is_package else name.split(".")[:-1]
        base = base[: len(base) - (node.level - 1)]
        return ".".join(base + ([node.module] if node.module else []))
    return node.module if node.module and node.module.startswith("backlash_df") else None


def _imports(name, path, modules):
    """``[(imported module, imported name or None)]`` of one module, relative imports resolved."""
    is_package = path.name == "__init__.py"
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [(alias.name, None) for alias in node.names if alias.name.startswith("backlash_df")]
        elif isinstance(node, ast.ImportFrom) and (target := _source_module(name, is_package, node)) is not None:
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


def _is_private(module):
    """True for a module with a ``_``-prefixed part (``backlash_df._laws``, ``backlash_df.describing._kernels``)."""
    return any(part.startswith("_") and not part.startswith("__") for part in module.split("."))


def _exports(modules):
    """``(exports, bindings, packages)`` of the package: each module's ``__all__`` (a literal list), the names
    its module-level ``from ... import`` binds as ``{name: (module, name there)}``, and the packages."""
    exports, bindings = {}, {}
    for name, path in modules.items():
        is_package = path.name == "__init__.py"
        tree = ast.parse(path.read_text(encoding="utf-8"))
        bound = bindings.setdefault(name, {})
        for node in tree.body:
            if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "__all__" for t in node.targets):
                exports[name] = list(ast.literal_eval(node.value))
            elif isinstance(node, ast.ImportFrom) and (target := _source_module(name, is_package, node)) is not None:
                for alias in node.names:
                    if f"{target}.{alias.name}" not in modules:
                        bound[alias.asname or alias.name] = (target, alias.name)
    packages = {name for name, path in modules.items() if path.name == "__init__.py"}
    return exports, bindings, packages


def _leaks(exports, bindings, packages):
    """``"module lists name from origin"`` for every name of a public module's ``__all__`` whose definition
    (followed through re-exports) lies in a ``_`` module of another package."""
    def origin(module, name, seen=()):
        source = bindings.get(module, {}).get(name)
        if source is None or (module, name) in seen:
            return module
        return origin(*source, seen + ((module, name),))

    def package(module):
        return module if module in packages else module.rpartition(".")[0]

    return sorted(f"{module} lists {name} from {found}" for module, names in exports.items() if not _is_private(module)
                  for name in names for found in [origin(module, name)]
                  if _is_private(found) and package(found) != package(module))


def test_no_public_module_lists_a_name_of_another_packages_private_module():
    assert _leaks(*_exports(_modules())) == []


def test_the_checker_sees_a_private_name_listed():
    # the test can fail: made-up modules, each name traced to where it is defined
    exports = {"pkg.sim": ["run", "step", "law", "own"], "pkg.models": ["law"], "pkg.desc": ["kern"],
               "pkg.sim.linear": ["law"], "pkg._laws": ["law"]}
    bindings = {"pkg.sim": {"run": ("pkg.sim._k", "run"), "step": ("pkg.desc._k", "step"), "law": ("pkg.models", "law")},
                "pkg.models": {"law": ("pkg._laws", "law")}, "pkg.desc": {"kern": ("pkg.desc._k", "kern")},
                "pkg.sim.linear": {"law": ("pkg._laws", "law")}}
    packages = {"pkg", "pkg.sim", "pkg.desc"}
    assert _leaks(exports, bindings, packages) == ["pkg.sim lists law from pkg._laws",
                                                   "pkg.sim lists step from pkg.desc._k",
                                                   "pkg.sim.linear lists law from pkg._laws"]


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
