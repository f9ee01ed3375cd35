"""numba's cache of phys2d's kernels is stamped with every module a kernel's module imports
(``phys2d.kernel_cache``): an edit of the sweep must reach the one-call tick that calls it."""

from __future__ import annotations

import shutil
from pathlib import Path

import numba
import pytest

import phys2d
from phys2d import kernel_cache
from phys2d.pipeline import tick

PACKAGE = Path(phys2d.__file__).resolve().parent


def names(paths: tuple[Path, ...], root: Path) -> set[str]:
    return {p.relative_to(root).as_posix() for p in paths}


def test_the_tick_depends_on_every_stage_it_calls() -> None:
    deps = names(kernel_cache.dependencies(PACKAGE / "pipeline/tick.py"), PACKAGE)
    # the stages the one-call tick runs, each in its own module
    stages = {
        "collision/broadphase.py",
        "collision/narrowphase.py",
        "collision/recycle.py",
        "constraints/rows.py",
        "constraints/joints.py",
        "contacts.py",
        "integrate.py",
        "responders/pgs.py",
        "responders/soft_step.py",
        "responders/restitution.py",
    }
    assert stages <= deps
    assert "recording/recorder.py" not in deps  # nothing the tick does not import
    # sort.py imports no other module of phys2d but jit.py, whose njit compiles every kernel
    assert names(kernel_cache.dependencies(PACKAGE / "collision/sort.py"), PACKAGE) == {"collision/sort.py", "jit.py"}


@pytest.fixture
def package_copy(tmp_path: Path) -> Path:
    copy = tmp_path / "phys2d"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
    yield copy
    forget()


def forget() -> None:
    for memo in (kernel_cache.imported_modules, kernel_cache.source_stamp, kernel_cache._file_record):
        memo.cache_clear()


def stamps(root: Path) -> dict[str, str]:
    forget()
    return {
        name: kernel_cache.source_stamp(root / name)
        for name in ("pipeline/tick.py", "responders/pgs.py", "collision/sort.py")
    }


def test_an_edit_restamps_exactly_the_kernels_that_import_it(package_copy: Path) -> None:
    before = stamps(package_copy)
    assert before == stamps(PACKAGE)  # the stamp reads contents, not where the files are
    pgs = package_copy / "responders" / "pgs.py"
    pgs.write_text(pgs.read_text() + "\n# a student's edit of the sweep\n")
    after = stamps(package_copy)
    assert after["responders/pgs.py"] != before["responders/pgs.py"]
    assert after["pipeline/tick.py"] != before["pipeline/tick.py"]  # the tick calls pgs_step: it must recompile
    assert after["collision/sort.py"] == before["collision/sort.py"]  # sort imports nothing of it


@pytest.mark.skipif(numba.config.DISABLE_JIT, reason="uncompiled kernels have no cache")
def test_phys2d_kernels_are_cached_under_the_stamp() -> None:
    locator = tick.tick._cache._impl.locator  # numba's cache of the kernel (numba internals)
    assert type(locator).__name__.startswith("PackageStamped")
    assert locator.get_source_stamp() == kernel_cache.source_stamp(PACKAGE / "pipeline/tick.py")
    assert kernel_cache.install()  # installing again changes nothing and reports it is in place
