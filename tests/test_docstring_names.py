"""Every module, class and function a docstring names in double backticks exists.

A dotted name in double backticks (``pipeline.tick.tick``, ``World.step``, ``Rows.view``) is read
as the code reads it: a name of phys2d's (a module, with its package or without, relative to the
docstring's own package, or a top-level class or function of any module; a record's fields count
as its attributes), then each part an attribute of the one before. A name whose first part is
none of phys2d's (a variable such as ``ctx.rows``) is not checked; a name whose first part is a
module of phys2d must be there, so ``shapes.pairs`` (the module ``phys2d.shapes`` has no
``pairs``) fails and ``ShapeRecord.pairs`` does not.
"""

from __future__ import annotations

import ast
import importlib
import pkgutil
import re
from pathlib import Path
from types import ModuleType

import phys2d

PACKAGE = Path(phys2d.__file__).parent
NAME = re.compile(r"``([A-Za-z_]\w*(?:\.[A-Za-z_]\w*)+)(?:\(\))?``")


def modules() -> dict[str, ModuleType]:
    """Every module of phys2d by its full name (the package's own included)."""
    found = {"phys2d": phys2d}
    for info in pkgutil.walk_packages(phys2d.__path__, "phys2d."):
        if info.name.endswith("__main__"):
            continue
        found[info.name] = importlib.import_module(info.name)
    return found


MODULES = modules()
BY_LAST: dict[str, list[ModuleType]] = {}
for _full, _module in MODULES.items():
    BY_LAST.setdefault(_full.rsplit(".", 1)[-1], []).append(_module)
TOP_LEVEL: dict[str, list[object]] = {}
for _module in MODULES.values():
    for _name, _value in vars(_module).items():
        if isinstance(_value, type) or callable(_value):
            if getattr(_value, "__module__", "") == _module.__name__:
                TOP_LEVEL.setdefault(_name, []).append(_value)


def attribute(owner: object, name: str) -> object | None:
    """owner.name, a submodule, or a record's field (its ``fields``); None when there is none."""
    if isinstance(owner, ModuleType):
        sub = MODULES.get(f"{owner.__name__}.{name}")
        if sub is not None:
            return sub
    for listed in ("fields", "__slots__", "_fields"):  # a record's, a slotted class's, a NamedTuple's
        names = getattr(owner, listed, ())
        if isinstance(names, (tuple, list)) and name in names:
            return name
    if isinstance(owner, type) and name in getattr(owner, "__annotations__", {}):
        return name
    try:
        return getattr(owner, name)
    except AttributeError:  # an instance attribute set in __init__: read its source
        if isinstance(owner, type):
            import inspect

            try:
                source = inspect.getsource(owner)
            except (OSError, TypeError):
                return None
            if re.search(rf"self\.{name}\b", source):
                return name
        return None


def resolves(start: object, parts: list[str]) -> bool:
    owner = start
    for part in parts:
        owner = attribute(owner, part)
        if owner is None:
            return False
    return True


def starts(first: str, module: ModuleType) -> list[object] | None:
    """What the first part of a name can be, in ``module``'s docstrings; None: not a name of phys2d's."""
    candidates: list[object] = []
    package = module.__name__ if hasattr(module, "__path__") else module.__name__.rsplit(".", 1)[0]
    for full in (f"phys2d.{first}", f"{package}.{first}"):
        if full in MODULES:
            candidates.append(MODULES[full])
    if first == "phys2d":
        candidates.append(phys2d)
    candidates += BY_LAST.get(first, [])
    if candidates:
        return candidates  # a module's name: the name must be there
    if first in vars(module) and not isinstance(vars(module)[first], (int, float, str, tuple, dict)):
        candidates.append(vars(module)[first])
    candidates += TOP_LEVEL.get(first, [])
    return candidates or None


def docstrings(path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text())
    found = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            doc = ast.get_docstring(node, clean=False)
            if doc:
                line = node.body[0].lineno if node.body else 0
                found.append((line, doc))
    return found


def test_every_dotted_name_in_a_docstring_is_there() -> None:
    missing = []
    for module in MODULES.values():
        if module.__file__ is None:
            continue
        path = Path(module.__file__)
        for line, doc in docstrings(path):
            for name in NAME.findall(doc):
                first, *rest = name.split(".")
                candidates = starts(first, module)
                if candidates is None:
                    continue  # a variable's attribute (``ctx.rows``), not a name of phys2d's
                if not any(resolves(c, rest) for c in candidates):
                    missing.append(f"{path.relative_to(PACKAGE.parent)}:{line}: ``{name}``")
    assert not missing, "docstrings name what is not there:\n" + "\n".join(missing)


def test_the_check_catches_a_name_that_is_not_there() -> None:
    """The resolver is not a rubber stamp: names that exist pass, invented ones fail."""
    world = MODULES["phys2d.world"]
    assert resolves(starts("pipeline", world)[0], ["tick", "tick"])  # type: ignore[index]
    assert resolves(starts("World", world)[0], ["step"])  # type: ignore[index]
    assert not any(resolves(c, ["stages", "tick"]) for c in starts("pipeline", world) or [])
    assert not any(resolves(c, ["pairs"]) for c in starts("shapes", world) or [])
    assert starts("ctx", world) is None
