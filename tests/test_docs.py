"""The README and the documentation pages work as written.

Every ```python block of ``README.md`` and the Markdown pages of ``docs/`` is run
(the blocks of one page in order, in one namespace, as a reader would paste them), and every ``backlash-df ...`` command of their shell blocks
is run and must exit 0.  Both run in a temporary copy of the repository's
``examples/`` folder, so relative paths such as ``examples/paper_rig.toml`` resolve
as they do from the repository root, and files the commands write land in the copy.
"""

import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
#: Not page sources: the build, and the copies docs/conf.py makes of notebooks/ and examples/ (git-ignored).
_SKIPPED_DOC_DIRS = {"_build", "notebooks", "_static", "examples"}

_FENCE = re.compile(r"^(?P<indent> *)(?P<fence>```+|~~~+)\s*\{?(?P<lang>[\w-]*)\}?[^\n]*\n(?P<body>.*?)^(?P=indent)(?P=fence)\s*$",
                    re.MULTILINE | re.DOTALL)
_SHELL_LANGUAGES = {"bash", "sh", "shell", "console", "shell-session"}


def markdown_pages():
    """README.md, every Markdown page of docs/ (not the build or the copies) and of examples/.

    The copies under docs/ exist only after a docs build, so globbing them made the
    collected tests depend on whether the docs had been built (602 on a fresh clone, 603
    after); the sources are collected instead.
    """
    pages = [ROOT / "README.md"]
    for path in sorted(DOCS.rglob("*.md")):
        if not _SKIPPED_DOC_DIRS.intersection(path.relative_to(DOCS).parts[:-1]):
            pages.append(path)
    return pages + sorted((ROOT / "examples").rglob("*.md"))


def code_blocks(path, languages):
    """The bodies of the fenced code blocks of ``path`` whose language is in ``languages``."""
    text = path.read_text(encoding="utf-8")
    return [match["body"] for match in _FENCE.finditer(text) if match["lang"].lower() in languages]


def shell_commands(block):
    """The commands of a shell block: prompts stripped, continuation lines joined."""
    commands, pending = [], ""
    for line in block.splitlines():
        line = re.sub(r"^\s*\$\s+", "", line).rstrip()
        if line.endswith("\\"):
            pending += line[:-1].strip() + " "
            continue
        command = " ".join((pending + line).split())
        pending = ""
        if command and not command.startswith("#"):
            commands.append(command)
    return commands


def backlash_df_commands(path):
    """Every ``backlash-df ...`` command shown in the shell blocks of ``path``.

    A chain such as ``pip install ... && backlash-df predict ...`` counts its
    ``backlash-df`` parts (the installation itself is what CI does).
    """
    return [part.strip() for block in code_blocks(path, _SHELL_LANGUAGES) for command in shell_commands(block)
            for part in command.split("&&") if part.split() and part.split()[0] == "backlash-df"]


def _page_id(path):
    return str(path.relative_to(ROOT))


def _python_cases():
    return [pytest.param(path, id=_page_id(path)) for path in markdown_pages() if code_blocks(path, {"python"})]


def _command_cases():
    """One case per distinct command (a command shown on several pages runs once)."""
    pages = {}
    for path in markdown_pages():
        for command in backlash_df_commands(path):
            pages.setdefault(command, []).append(_page_id(path))
    return [pytest.param(command, id=f"{command} [{', '.join(dict.fromkeys(where))}]")
            for command, where in pages.items()]


@pytest.fixture
def repo_copy(tmp_path, monkeypatch):
    """A scratch working directory holding a copy of ``examples/``, as seen from the repo root."""
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _console_script():
    """The ``backlash-df`` script of the running interpreter's environment."""
    script = shutil.which("backlash-df", path=str(Path(sys.executable).parent)) or shutil.which("backlash-df")
    assert script, "the backlash-df console script is not installed (pip install -e .)"
    return script


def test_the_pages_show_code():
    """The extraction itself works: the README shows commands, the theory page no code."""
    assert ROOT / "README.md" in markdown_pages()
    assert DOCS / "theory.md" in markdown_pages()
    assert not any("_build" in path.parts for path in markdown_pages())
    sample = "```bash\n$ backlash-df predict a.toml \\\n    --json out.json\n# comment\n```\n"
    match = _FENCE.search(sample)
    assert shell_commands(match["body"]) == ["backlash-df predict a.toml --json out.json"]
    readme_commands = backlash_df_commands(ROOT / "README.md")
    assert any(command.startswith("backlash-df predict examples/") for command in readme_commands)


@pytest.mark.parametrize("path", _python_cases())
def test_python_blocks_run(path, repo_copy):
    """All ```python blocks of one page run in order in one namespace."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    namespace = {"__name__": "__docs__"}
    try:
        for number, block in enumerate(code_blocks(path, {"python"}), start=1):
            code = compile(block, f"{_page_id(path)} [python block {number}]", "exec")
            exec(code, namespace)  # noqa: S102 - the documented code is the test
    finally:
        plt.close("all")


@pytest.mark.parametrize("command", _command_cases())
def test_backlash_df_commands_run(command, repo_copy):
    """Every ``backlash-df`` command shown exits 0 (run from a copy of the repo root)."""
    argv = [_console_script(), *shlex.split(command)[1:]]
    env = {**os.environ, "MPLBACKEND": "Agg"}
    result = subprocess.run(argv, cwd=repo_copy, env=env, capture_output=True, text=True, timeout=600,
                            stdin=subprocess.DEVNULL)
    assert result.returncode == 0, f"{command!r} exited {result.returncode}:\n{result.stderr[-3000:]}"
    if command in CONTRACT_DOCUMENTS:
        _check_contract_document(command, repo_copy)


def _contract_documents():
    """Per command of a "### `X --json`" section of the contract page: (its first JSON excerpt, its table's keys)."""
    text = (DOCS / "contract.md").read_text(encoding="utf-8").split("## JSON documents of the command line", 1)[1]
    documents = {}
    for section in re.split(r"^### ", text, flags=re.MULTILINE)[1:]:
        section = re.split(r"^## ", section, flags=re.MULTILINE)[0]
        blocks = {lang: [m["body"] for m in _FENCE.finditer(section) if m["lang"] == lang] for lang in ("bash", "json")}
        if blocks["bash"] and blocks["json"]:
            rows = dict(re.findall(r"^\| `([^`]+)` \|(.*)$", section, flags=re.MULTILINE))
            documents[shell_commands(blocks["bash"][0])[0]] = (json.loads(blocks["json"][0]), rows)
    return documents


CONTRACT_DOCUMENTS = _contract_documents()


def _key_paths(document, prefix=""):
    """Every key of a JSON document as a path, ``a.b`` and ``a[].b`` for the entries of a list."""
    paths = set()
    if isinstance(document, dict):
        for key, value in document.items():
            path = f"{prefix}.{key}" if prefix else key
            paths |= {path} | _key_paths(value, path)
    elif isinstance(document, list):
        for value in document:
            paths |= _key_paths(value, prefix + "[]")
    return paths


def _check_contract_document(command, repo_copy):
    """The contract page's excerpt holds only keys the command writes, and its table names every key written.

    A key is named by its own row or by an ancestor's row whose meaning says ``keys as`` another
    object's.  The diagnosis table names its parameters and signals by placeholders (``NAME``,
    ``SPEED``): only its excerpt is checked.
    """
    excerpt, rows = CONTRACT_DOCUMENTS[command]
    argv = shlex.split(command)
    written = json.loads((repo_copy / argv[argv.index("--json" if "--json" in argv else "--out") + 1]).read_text())
    keys = _key_paths(written)
    assert not _key_paths(excerpt) - keys, f"the contract's excerpt of {command!r} shows keys it does not write"
    if any("NAME" in row for row in rows):
        return
    by_reference = [row for row, meaning in rows.items() if "keys as" in meaning]
    unnamed = {key for key in keys - set(rows) if not any(key.startswith(row + ".") for row in by_reference)}
    assert not unnamed, f"the contract's table of {command!r} does not name the keys {sorted(unnamed)}"


def _rig_cases():
    return [pytest.param(block, id=f"{_page_id(path)} [toml block {number}]")
            for path in markdown_pages()
            for number, block in enumerate(code_blocks(path, {"toml"}), start=1) if "[plant]" in block]


@pytest.mark.parametrize("block", _rig_cases())
def test_rig_file_examples_load(block):
    """Every complete rig file shown in the pages is one the loader accepts."""
    import tomllib

    from backlash_df import rig_from_dict

    rig = rig_from_dict(tomllib.loads(block), source="docs")
    assert rig.plant.stiffness > 0


# --------------------------------------------------------------------------- the built documentation


def _api_top_level_names():
    """The names listed under "Top-level names" in docs/api.md."""
    text = (DOCS / "api.md").read_text(encoding="utf-8")
    block = text.split("Top-level names", 1)[1].split(".. autosummary::", 1)[1].split("```", 1)[0]
    return [line.strip() for line in block.splitlines() if line.strip() and not line.strip().startswith(":")]


def test_api_page_lists_exactly_the_exports():
    import backlash_df

    listed = _api_top_level_names()
    exported = [name for name in backlash_df.__all__ if name != "__version__"]
    assert len(listed) == len(set(listed))
    assert sorted(listed) == sorted(exported)
    for name in exported:
        assert getattr(backlash_df, name) is not None


def _build_docs(out):
    """A quick HTML build into ``out`` (notebooks not executed; their outputs reference nothing remote)."""
    env = {**os.environ, "BACKLASH_DF_DOCS_EXECUTE": "off", "MPLBACKEND": "Agg"}
    result = subprocess.run([sys.executable, "-m", "sphinx", "-q", "-b", "html", str(DOCS), str(out)],
                            cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr[-3000:]


_ON_ONE_WORKER = pytest.mark.xdist_group("built-docs")  # one worker builds and reads; the other is not left waiting on the lock


@pytest.fixture(scope="module")
def built_docs(tmp_path_factory):
    """The HTML documentation: CI's build if it is newer than the sources of this check, else one
    quick build per test run, shared by pytest-xdist's workers under a lock (a build copies the
    notebooks into docs/, so two at once would race)."""
    html = DOCS / "_build" / "html"
    sources = [DOCS / "conf.py", DOCS / "api.md", DOCS / "theory.md"]
    if (html / "index.html").exists() and all((html / "index.html").stat().st_mtime > p.stat().st_mtime for p in sources):
        return html
    run = os.environ.get("PYTEST_XDIST_TESTRUNUID")
    if run is None:
        out = tmp_path_factory.mktemp("html")
        _build_docs(out)
        return out
    import fcntl

    out = tmp_path_factory.getbasetemp().parent / f"docs-html-{run}"
    with open(f"{out}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (out / "index.html").exists():
            _build_docs(out)
    return out


_REMOTE = re.compile(r"""<(?:script|link|img|iframe)\b[^>]*\b(?:src|href)\s*=\s*["']((?:https?:)?//[^"']+)["'][^>]*>""",
                     re.IGNORECASE)


@_ON_ONE_WORKER
def test_built_pages_load_nothing_from_the_network(built_docs):
    """Offline reading: no page loads a script, stylesheet or image from another host."""
    pages = sorted(built_docs.rglob("*.html"))
    assert len(pages) > 5
    remote = {}
    for page in pages:
        for match in _REMOTE.finditer(page.read_text(encoding="utf-8")):
            tag = match.group(0)
            if tag.lower().startswith("<link") and "stylesheet" not in tag and "preload" not in tag:
                continue  # a hyperlink-like <link> (canonical, next, search) loads nothing
            remote.setdefault(page.relative_to(built_docs).as_posix(), []).append(match.group(1))
    assert remote == {}


@_ON_ONE_WORKER
def test_math_is_rendered_by_the_bundled_mathjax(built_docs):
    """The theory page (TeX in $...$) loads MathJax from _static, and the files are there, fonts included."""
    theory = (built_docs / "theory.html").read_text(encoding="utf-8")
    assert re.search(r'<script[^>]*src="_static/mathjax/tex-chtml\.js(\?v=[0-9a-f]+)?"', theory)  # Sphinx's ?v= tag
    assert r"\(" in theory or r"\[" in theory  # math left to MathJax, not dropped
    mathjax = built_docs / "_static" / "mathjax"
    assert (mathjax / "tex-chtml.js").stat().st_size > 100_000
    assert list((mathjax / "output" / "chtml" / "fonts" / "woff-v2").glob("*.woff"))


@_ON_ONE_WORKER
def test_theory_math_renders_offline_in_a_browser(built_docs, tmp_path):
    """Headless chromium with every network request sent to a dead proxy: MathJax typesets the
    theory page's equations, the paper's tagged ones included, and none is an error."""
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        message = "chromium is not installed (Debian: apt-get install chromium)"
        if os.environ.get("CI", "").lower() in {"1", "true", "yes"}:
            pytest.fail(message)
        pytest.skip(message)
    flags = ["--headless", "--no-sandbox", "--disable-gpu", "--proxy-server=127.0.0.1:9", "--virtual-time-budget=15000",
             f"--user-data-dir={tmp_path}", "--dump-dom"]
    result = subprocess.run([chromium, *flags, (built_docs / "theory.html").as_uri()], capture_output=True, text=True,
                            timeout=180, stdin=subprocess.DEVNULL)
    dom = result.stdout
    assert dom.count("<mjx-container") >= 20, result.stderr[-2000:]
    assert "<mjx-merror" not in dom
    assert 'data-mjx-error' not in dom


# --------------------------------------------------------------------------- a model's .plot()


@pytest.mark.parametrize("name", ["phase-plane", "rubber", "dead-zone", "exact"])
def test_model_plot_shows_the_law(name):
    """The colour map of a model's .plot() is its torque on the drawn grid (the exact model: in contact)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from backlash_df import make_model

    k, c, alpha = 5895.0, 3.0, 0.05
    model = make_model(name, stiffness=k, damping=c, half_gap=alpha, rubber_thickness=0.02)
    ax = model.plot(n=41).ax
    try:
        mesh = ax.collections[0]
        x, v = np.meshgrid(np.linspace(-3 * alpha, 3 * alpha, 41), np.linspace(-3 * alpha * k / c, 3 * alpha * k / c, 41))
        if name == "exact":  # (1) with theta_b = +-alpha outside the release set (5)
            y = k * x + c * v
            expected = np.where(np.abs(y) >= k * alpha, y - np.sign(y) * k * alpha, 0.0)
        else:
            expected = model.torque(x, v)
        np.testing.assert_allclose(np.asarray(mesh.get_array()).reshape(x.shape), expected, rtol=1e-12, atol=1e-9)
        assert ax.get_xlabel() == "theta_d (rad)" and "(rad/s)" in ax.get_ylabel()
    finally:
        plt.close("all")
