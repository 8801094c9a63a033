"""Dependencies as imported: pyproject.toml declares what the code imports, and nothing else.

Every third-party module a file imports (at its top, inside a function, or by name through
``importlib`` / ``pytest.importorskip``) is read with ``ast``, mapped to the distribution that
provides it, and held to pyproject.toml: the package's imports to its dependencies and extras,
the tests' to those and the test extra, the benchmarks' to those and the bench extra. The other
way round, every hard dependency must be imported by some module of the package: one nobody
imports costs every user an install for nothing (scipy and imageio did). The package root is
never imported by a module of the package, which keeps the lazy API free of import circles.
"""
from __future__ import annotations

import ast
import functools
import importlib.metadata
import re
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from helpers import ROOT, parsed

tomllib = pytest.importorskip("tomllib" if sys.version_info >= (3, 11) else "tomli")

PACKAGE_FOLDERS = ("foundation", "dsl", "runtime", "backends")

# The distribution that provides a module, where the two names differ (else the module's name,
# lower case, "_" as "-"). A new import of a module named unlike its distribution goes here.
DISTRIBUTION = {
    "PIL": "pillow",
    "cv2": "opencv-python-headless",
    "yaml": "pyyaml",
    "zmq": "pyzmq",
    "irsim": "ir-sim",
    "xdist": "pytest-xdist",
    "_pytest": "pytest",
    "_hypothesis_pytestplugin": "hypothesis",
    "distributed": "dask",  # through the dask extra's dask[distributed]
}
# Modules the package imports that its host provides: the pytest plugin runs inside pytest.
HOSTED = {"pytest", "_pytest"}


def normal(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def distribution(module: str) -> str:
    return normal(DISTRIBUTION.get(module, module))


@functools.cache
def pyproject() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))


def names(requirements: list[str]) -> set[str]:
    """The distributions a list of requirements names (``dask[distributed]>=2024.1`` -> dask)."""
    return {normal(re.match(r"[A-Za-z0-9._-]+", r).group(0)) for r in requirements}  # type: ignore[union-attr]


def hard() -> set[str]:
    return names(pyproject()["project"]["dependencies"])


def every_extra() -> set[str]:
    extras = pyproject()["project"]["optional-dependencies"]
    return set().union(*(names(requirements) for requirements in extras.values())) - {"labsim"}


def string_imports(node: ast.AST) -> Iterator[str]:
    """Modules named in a call: importlib.import_module("x"), find_spec("x"), importorskip("x")."""
    if isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant):
        func = node.func
        called = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
        if called in ("import_module", "find_spec", "importorskip") and isinstance(node.args[0].value, str):
            yield node.args[0].value


def tree(path: Path) -> ast.Module:
    return parsed(path)[1]


def imports(files: list[Path]) -> dict[str, set[str]]:
    """{top-level third-party module: the files that import it} (labsim's own and the standard
    library's left out; relative imports are labsim's)."""
    out: dict[str, set[str]] = {}
    for path in files:
        for node in ast.walk(tree(path)):
            found: list[str] = []
            if isinstance(node, ast.Import):
                found = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                found = [node.module]
            found += string_imports(node)
            for module in found:
                top = module.split(".")[0]
                if top not in sys.stdlib_module_names and top not in ("labsim", "__future__"):
                    out.setdefault(top, set()).add(path.relative_to(ROOT).as_posix())
    return out


def package_files() -> list[Path]:
    files = sorted(ROOT.glob("*.py"))
    for folder in PACKAGE_FOLDERS:
        files += sorted((ROOT / folder).rglob("*.py"))
    return files


def local(folder: Path) -> set[str]:
    """The modules a folder's files import from each other (tests/helpers.py, benchmarks/compare.py)."""
    return {p.stem for p in folder.glob("*.py")}


def undeclared(found: dict[str, set[str]], declared: set[str]) -> list[str]:
    return sorted(f"{module} ({distribution(module)}), imported by {', '.join(sorted(files))}"
                  for module, files in found.items() if distribution(module) not in declared)


def test_every_module_the_package_imports_is_declared() -> None:
    found = {m: f for m, f in imports(package_files()).items() if m not in HOSTED}
    assert undeclared(found, hard() | every_extra()) == [], \
        "imported but not in pyproject.toml's dependencies or an extra (or DISTRIBUTION lacks its name)"


def test_every_hard_dependency_is_imported_by_the_package() -> None:
    imported = {distribution(m) for m in imports(package_files())}
    assert sorted(hard() - imported) == [], \
        "a hard dependency no module of labsim imports: remove it, or move it to the extra that needs it"


def test_the_tests_and_benchmarks_import_only_what_an_extra_installs() -> None:
    """(A test of an extra's feature skips without it: ``pytest.importorskip``.)"""
    found: dict[str, set[str]] = {}
    for folder in (ROOT / "tests", ROOT / "benchmarks"):
        for module, files in imports(sorted(folder.rglob("*.py"))).items():
            if module not in local(folder):
                found.setdefault(module, set()).update(files)
    assert undeclared(found, hard() | every_extra()) == []


def test_the_distribution_table_is_what_is_installed() -> None:
    """DISTRIBUTION must not lie: where its distribution is installed here, it holds the module.
    ``distributed`` comes through dask's extra, by design. (One distribution's file list each:
    ``packages_distributions()`` reads every installed one's, seconds of CPU.)"""
    wrong = []
    for module in sorted(set(DISTRIBUTION) - {"distributed"}):
        try:
            files = importlib.metadata.distribution(distribution(module)).files or []
        except importlib.metadata.PackageNotFoundError:
            continue
        if not any(f.parts[0].split(".")[0] == module for f in files):
            wrong.append(f"{module}: not among the files of {distribution(module)}")
    assert wrong == []


def test_no_module_of_the_package_imports_the_package_root() -> None:
    """``labsim/__init__.py`` imports the API on first use, and the API the tick loop: a module
    below that imported ``labsim`` itself (for ``__version__``, say) would close a circle."""
    roots = []
    for path in package_files():
        if path.parent == ROOT:
            continue
        for node in ast.walk(tree(path)):
            if (isinstance(node, ast.Import) and any(a.name == "labsim" for a in node.names)) or (
                    isinstance(node, ast.ImportFrom) and node.level == 0 and node.module == "labsim"):
                roots.append(f"{path.relative_to(ROOT).as_posix()}:{node.lineno}")
    assert roots == [], "import labsim.foundation.version (or the module meant), not the package root"


def test_the_version_is_the_installed_distributions() -> None:
    import labsim
    from labsim.foundation.version import version

    assert labsim.__version__ == version() == importlib.metadata.version("labsim")
    assert "__version__ =" not in (ROOT / "__init__.py").read_text(encoding="utf-8")
