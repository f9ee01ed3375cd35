"""numba's on-disk cache of the kernels, kept in step with every module a kernel calls into.

numba stamps a cached kernel with its own source file only, so a kernel that calls a kernel
of another module keeps running the old machine code after that module is edited (numba's
documented limit). The one-call tick (``pipeline.tick.tick``) calls into nearly every module: edit
``responders/pgs.py``'s sweep and ``World.step`` would go on running the old one, with no
sign of it. Here a phys2d kernel's stamp is the contents of its own module and of every
phys2d module that module imports, directly or through others, so an edit recompiles
exactly the kernels that may call the edited code (the tick's after any edit of the
pipeline; ``collision/sort.py``'s only after an edit of itself).

``install()`` runs when this module is imported, which phys2d's ``__init__`` does before
any of its kernels is defined. It puts
stamped twins of numba's locators (a user-given NUMBA_CACHE_DIR, the package's
``__pycache__``, the user-wide cache) ahead of numba's own, for phys2d's files only; with
a numba whose locators it does not find it changes nothing.
"""

from __future__ import annotations

import hashlib
import re
from functools import cache
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent

# "from .x.y import a" / "from ..x import (a," / "from . import a, b" / "from phys2d.x import a"
_FROM_IMPORT = re.compile(r"^[ \t]*from[ \t]+(\.+|phys2d\b\.?)([\w.]*)[ \t]+import[ \t]+\(?([\w \t,]*)", re.MULTILINE)


def package_root(path: Path) -> Path:
    """The top package directory holding the module at ``path`` (phys2d's own, for phys2d)."""
    root = path.parent
    while (root.parent / "__init__.py").is_file():
        root = root.parent
    return root


def _module_file(base: Path, dotted: str) -> Path | None:
    """The file of module ``dotted`` under package directory ``base`` (a module or a package)."""
    path = base.joinpath(*dotted.split(".")) if dotted else base
    for candidate in (path.with_suffix(".py"), path / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


@cache
def imported_modules(path: Path) -> tuple[Path, ...]:
    """The phys2d modules the file at ``path`` imports itself (relative or ``phys2d.``
    imports, anywhere in it: a superset of what its kernels call is safe)."""
    found: set[Path] = set()
    for dots, module, names in _FROM_IMPORT.findall(path.read_text(encoding="utf-8")):
        if dots.startswith("."):
            base = path.parent
            for _ in range(len(dots) - 1):
                base = base.parent
        else:
            base = package_root(path)
        target = _module_file(base, module)
        if target is not None:
            found.add(target)
        if module == "":  # "from . import a, b": a and b may be modules
            for name in names.replace(",", " ").split():
                sub = _module_file(base, name)
                if sub is not None:
                    found.add(sub)
    found.discard(path)
    return tuple(sorted(found))


def dependencies(path: Path) -> tuple[Path, ...]:
    """``path`` and every phys2d module it imports, directly or through others, sorted."""
    seen = {path}
    todo = [path]
    while todo:
        for module in imported_modules(todo.pop()):
            if module not in seen:
                seen.add(module)
                todo.append(module)
    return tuple(sorted(seen))


@cache
def _file_record(path: Path) -> bytes:
    """One module's name in its package and the sha256 of its contents (each file is read
    once, however many kernels' stamps it enters)."""
    name = path.relative_to(package_root(path)).as_posix().encode()
    return name + b"\0" + hashlib.sha256(path.read_bytes()).digest()


@cache
def source_stamp(path: Path) -> str:
    """A digest of the contents of ``path`` and of its ``dependencies``: what a cached kernel
    defined in ``path`` is valid for."""
    return hashlib.sha256(b"".join(_file_record(module) for module in dependencies(path))).hexdigest()


def in_package(py_file: str) -> Path | None:
    """The resolved path of ``py_file`` when it is one of phys2d's modules, else None."""
    path = Path(py_file).resolve()
    return path if path.suffix == ".py" and PACKAGE in path.parents else None


def _stamped(locator: type) -> type:
    """A locator like ``locator`` for phys2d's files, stamped with ``source_stamp``."""

    class PackageStamped(locator):
        def get_source_stamp(self) -> str:
            return source_stamp(Path(self._py_file).resolve())

        @classmethod
        def from_function(cls, py_func, py_file):
            if in_package(py_file) is None:
                return None  # not phys2d's: numba's own locators take it
            return super().from_function(py_func, py_file)

    PackageStamped.__name__ = PackageStamped.__qualname__ = "PackageStamped" + locator.__name__.lstrip("_")
    return PackageStamped


def install() -> bool:
    """Put the stamped locators ahead of numba's own (once); False when this numba has no
    locators by the names looked for (then numba's stamps stay)."""
    try:
        from numba.core import caching
    except ImportError:  # pragma: no cover - numba is a dependency
        return False
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    names = ("UserProvidedCacheLocator", "InTreeCacheLocator", "UserWideCacheLocator")
    found = [getattr(caching, name, None) or getattr(caching, "_" + name, None) for name in names]
    bases = [base for base in found if isinstance(base, type)]
    if impl is None or len(bases) < len(names):
        return False
    classes = list(impl._locator_classes)
    if any(getattr(c, "__name__", "").startswith("PackageStamped") for c in classes):
        return True
    impl._locator_classes = [_stamped(base) for base in bases] + classes
    return True


install()
