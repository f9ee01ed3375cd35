"""The project around the engine: the public API's shape, one version, one list of
responders, declared dependencies, and links a clone can follow."""

from __future__ import annotations

import ast
import inspect
import re
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

import phys2d
from phys2d.responders import REGISTRY

ROOT = Path(__file__).resolve().parents[1]

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())

# -- the public API: everything after position (after the two bodies for joints) by keyword -----

ADDERS = {
    "add_box": "position",
    "add_circle": "position",
    "add_polygon": "position",
    "add_capsule": "position",
    "add_segment": "b",
    "add_chain": "points",
    "add_distance_joint": "b",
    "add_pin_joint": "b",
    "add_angle_joint": "b",
}


@pytest.mark.parametrize("method, last", ADDERS.items())
def test_add_methods_take_keywords_after_position(method: str, last: str) -> None:
    """In the signature: nothing positional after ``last`` (keyword-only, or the body options
    ``**options: Unpack[BodyOptions]``), and every parameter annotated."""
    params = list(inspect.signature(getattr(phys2d.World, method)).parameters.values())
    names = [p.name for p in params]
    cut = names.index(last) + 1
    assert all(p.kind is p.POSITIONAL_OR_KEYWORD for p in params[:cut])
    assert params[cut:] and all(p.kind in (p.KEYWORD_ONLY, p.VAR_KEYWORD) for p in params[cut:]), names
    assert all(p.annotation is not p.empty for p in params[1:]), names
    assert inspect.signature(getattr(phys2d.World, method)).return_annotation is not inspect.Signature.empty


TRIANGLE = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)]


@pytest.mark.parametrize(
    "call",
    [
        lambda w: w.add_box((0.0, 0.0), (0.5, 0.5)),
        lambda w: w.add_circle((0.0, 0.0), 0.5),
        lambda w: w.add_polygon((0.0, 0.0), TRIANGLE),
        lambda w: w.add_box((0.0, 0.0), (0.5, 0.5), 0.0, 1.0),
        lambda w: w.add_capsule((0.0, 0.0), 0.5, 0.2),
        lambda w: w.add_segment((0.0, 0.0), (1.0, 0.0), 0.1),
        lambda w: w.add_chain([(0.0, 0.0), (1.0, 0.0)], True),
    ],
    ids=["box", "circle", "polygon", "box-four", "capsule", "segment", "chain"],
)
def test_positional_arguments_past_position_are_refused(call) -> None:
    w = phys2d.World()
    with pytest.raises(TypeError, match="positional argument"):
        call(w)
    assert len(w) == 0


def test_positional_joint_arguments_past_the_bodies_are_refused() -> None:
    w = phys2d.World()
    a = w.add_box(position=(0.0, 0.0))
    b = w.add_box(position=(2.0, 0.0))
    for call in (
        lambda: w.add_distance_joint(a, b, (0.0, 0.0)),
        lambda: w.add_pin_joint(a, b, (1.0, 0.0)),
        lambda: w.add_angle_joint(a, b, -0.5, 0.5),
    ):
        with pytest.raises(TypeError, match="positional argument"):
            call()
        assert w.joints == ()
    assert w.add_pin_joint(a, b, anchor=(1.0, 0.0)).alive  # by keyword it is taken


def test_add_polygon_needs_its_vertices() -> None:
    w = phys2d.World()
    with pytest.raises(TypeError, match="vertices"):
        w.add_polygon(position=(0.0, 0.0))  # type: ignore[call-arg]
    assert len(w) == 0
    body = w.add_polygon((1.0, 2.0), vertices=TRIANGLE)  # position may still come first
    assert body.position == pytest.approx((1.0, 2.0))
    assert body.mass == pytest.approx(0.5)  # the right triangle's area at density 1


# -- one version -------------------------------------------------------------------------


def test_the_version_is_written_once() -> None:
    """pyproject.toml takes the version from phys2d.__version__ (setuptools reads it there,
    as the build does), and ``phys2d --version`` prints it."""
    assert "version" not in PYPROJECT["project"]
    assert "version" in PYPROJECT["project"]["dynamic"]
    assert PYPROJECT["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "phys2d.__version__"}
    # the second method: the assignment in phys2d/__init__.py, read as setuptools reads it
    tree = ast.parse((ROOT / "phys2d" / "__init__.py").read_text())
    written = [
        n.value.value
        for n in tree.body
        if isinstance(n, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "__version__" for t in n.targets)
    ]
    assert written == [phys2d.__version__]
    assert re.fullmatch(r"\d+\.\d+\.\d+", phys2d.__version__)
    pyproject_config = pytest.importorskip("setuptools.config.pyprojecttoml")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # setuptools calls its [tool.setuptools] support beta
        built = pyproject_config.read_configuration(ROOT / "pyproject.toml", expand=True)
    assert built["project"]["version"] == phys2d.__version__
    out = subprocess.run(
        [sys.executable, "-m", "phys2d", "--version"], capture_output=True, text=True, cwd=ROOT, check=True
    ).stdout
    assert out.startswith(f"phys2d {phys2d.__version__} ")


# -- the registry is the one list of responders ------------------------------------------------


def readme_responder_table() -> list[list[str]]:
    """The rows of the README's table of registered responders, cells stripped."""
    text = (ROOT / "README.md").read_text()
    header = "| name | what it is | count | in Python | what a student sees |"
    assert text.count(header) == 1
    lines = text[text.index(header) :].splitlines()[2:]
    rows = []
    for line in lines:
        if not line.startswith("|"):
            break
        rows.append([cell.strip() for cell in line.strip().strip("|").split("|")])
    return rows


def test_readme_table_names_exactly_the_registry() -> None:
    """Every registered responder has a row, in the registry's order, with its description,
    its count's name, and a Python spelling that builds the same responder."""
    rows = readme_responder_table()
    assert [r[0] for r in rows] == [f"`{name}`" for name in REGISTRY]
    for name, what, count, python, _ in rows:
        entry = REGISTRY[name.strip("`")]
        assert what == entry.description
        assert count == (entry.count or "")
        expression = python.strip("`")
        assert expression.startswith("phys2d.")
        assert repr(eval(expression, {"phys2d": phys2d})) == repr(entry())


def test_the_strategies_cover_the_registry() -> None:
    """tests/strategies.py draws responders by registered name, with settings for each."""
    from tests import strategies

    assert list(strategies.RESPONDER_SETTINGS) == list(REGISTRY)


# -- dependencies ------------------------------------------------------------------------------

# import name -> distribution name, where they differ
DISTRIBUTION = {
    "PIL": "pillow",
    "websocket": "websocket-client",
    "rerun": "rerun-sdk",
    "rerun_cli": "rerun-sdk",
    "rerun_bindings": "rerun-sdk",
    "rerun_notebook": "rerun-notebook",
    "IPython": "ipython",
    "Box2D": "box2d",
    "yaml": "pyyaml",
}
LOCAL = {
    "phys2d",
    "tests",
    "_common",
    "engines",
    "box2d_v3",
    "floor",
    "perf_kernels",
    "webview",
    "conftest",
    "strategies",
    "your_responder",
}


def third_party_imports(root: Path) -> set[str]:
    """Top-level names of the modules imported anywhere under ``root`` that are neither the
    standard library nor the project's own."""
    names: set[str] = set()
    for path in root.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names.update(a.name.split(".")[0] for a in node.names)
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names.add(node.module.split(".")[0])
    return {n for n in names if n not in sys.stdlib_module_names and n not in LOCAL}


def declared(requirements: list[str]) -> set[str]:
    """Distribution names of requirement strings, lower case, with extras followed."""
    out: set[str] = set()
    extras = PYPROJECT["project"]["optional-dependencies"]
    for req in requirements:
        name = re.match(r"[A-Za-z0-9_.\-]+", req).group(0).lower()
        if name == "phys2d":  # phys2d[sweep,plots]: those extras
            for extra in re.search(r"\[(.*)\]", req).group(1).split(","):
                out |= declared(extras[extra.strip()])
        else:
            out.add(name)
    return out


@pytest.mark.parametrize(
    "folder, extras",
    [
        # test: hypothesis, for phys2d.testing (not imported by phys2d); dev: typing_extensions, for mypy only
        ("phys2d", ["sweep", "test", "dev"]),
        ("lessons", ["notebook"]),
        ("tests", ["test"]),
        ("benchmarks", ["bench", "test"]),
    ],
)
def test_every_import_is_declared(folder: str, extras: list[str]) -> None:
    """Each third-party module a folder imports comes from a distribution that the core
    dependencies or that folder's extras name."""
    core = PYPROJECT["project"]["dependencies"]
    have = declared(core + [r for e in extras for r in PYPROJECT["project"]["optional-dependencies"][e]])
    missing = {m for m in third_party_imports(ROOT / folder) if DISTRIBUTION.get(m, m).lower() not in have}
    assert not missing, f"{folder}/ imports {sorted(missing)}, declared nowhere in pyproject.toml"


def test_the_ci_installs_its_tools_and_runs_the_readme_test_command() -> None:
    ci = (ROOT / ".ci" / "run").read_text()
    assert re.search(r'pip install .*-e "\.\[test,dev\]"', ci)
    assert {"ruff", "mypy"} <= declared(PYPROJECT["project"]["optional-dependencies"]["dev"])
    readme = (ROOT / "README.md").read_text()
    command = re.search(r'pip install -e "\.\[test\]" && (.*?)\s+#', readme).group(1)
    lines = [line.strip() for line in ci.splitlines()]
    assert (
        lines.index("python -m ruff check .")
        < lines.index("python -m ruff format --check .")
        < lines.index("python -m mypy")
        < lines.index(command)
    )


# -- links a clone can follow --------------------------------------------------------------------


def markdown_files() -> list[Path]:
    return [
        ROOT / "README.md",
        *sorted((ROOT / "lessons").glob("*.md")),
        *sorted((ROOT / "docs").glob("*.md")),
        *sorted((ROOT / "benchmarks").glob("*.md")),
    ]


def anchors(path: Path) -> set[str]:
    """GitHub's anchors for the headings of a Markdown file."""
    out = set()
    for line in path.read_text().splitlines():
        m = re.match(r"#+ (.*)", line)
        if m:
            slug = re.sub(r"[^\w\- ]", "", m.group(1).strip().lower()).replace(" ", "-")
            out.add(slug)
    return out


LINK = re.compile(r"\]\(([^)\s]+)\)")


@pytest.mark.parametrize("path", markdown_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_markdown_links_stay_in_the_repository(path: Path) -> None:
    """Every relative link names a file of the repository (and a heading of it, with #)."""
    for target in LINK.findall(path.read_text()):
        if re.match(r"[a-z]+:", target) or target.startswith("#"):
            continue  # a web address, or a heading of the same file
        file, _, anchor = target.partition("#")
        resolved = (path.parent / file).resolve()
        assert resolved.is_relative_to(ROOT), f"{path.name} links outside the repository: {target}"
        assert resolved.exists(), f"{path.name} links to a missing file: {target}"
        if anchor and resolved.suffix == ".md":
            assert anchor in anchors(resolved), f"{path.name}: no heading #{anchor} in {file}"


DOC_REFERENCE = re.compile(r"docs/(\w+\.md)(?:#([\w\-]+))?")
OUTSIDE = ("../" + "shared/", "FORMULATION" + ".md")  # documents a clone does not have
# files whose owners replace these references in their own branches (issue 13)
NOT_YET: set[str] = set()  # every module now cites docs/formulation.md


def test_docstrings_name_documents_that_exist() -> None:
    """References to docs/*.md in the code and tests name files (and headings) that exist,
    and nothing points at a document outside the repository."""
    for folder in ("phys2d", "tests", "lessons", "benchmarks"):
        for path in (ROOT / folder).rglob("*.py"):
            text = path.read_text()
            if str(path.relative_to(ROOT)) not in NOT_YET:
                assert not any(o in text for o in OUTSIDE), path
            for file, anchor in DOC_REFERENCE.findall(text):
                assert (ROOT / "docs" / file).exists(), (path, file)
                if anchor:
                    assert anchor in anchors(ROOT / "docs" / file), (path, anchor)
