"""Build Box2D v3 from a source tree the user gives, with our harness, into one shared library.

``peers.py --box2d-v3 PATH`` calls ``build(PATH)``:

1. Box2D v3's own CMake builds its static library: Release (``-O3 -DNDEBUG``,
   plus Box2D's own ``-ffp-contract=off``), the default SIMD path (SSE2 on
   x86-64: ``BOX2D_AVX2`` stays off), position-independent code, samples,
   unit tests, benchmarks and docs off.
2. The system C compiler (``$CC``, else ``cc``) compiles ``box2d_v3_harness.c``
   (phys2d's own code, calling only Box2D's public API) and links it with that
   library into ``libbox2d_v3_harness.so``, which ``engines.Box2DV3Adapter``
   loads with ctypes.

The build goes to ``benchmarks/build/box2d-v3/<tree>/`` (``build/`` is ignored
by git), one folder per source tree; a second run rebuilds only what changed.
Nothing of Box2D is copied into this repository.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

BENCH_DIR = Path(__file__).resolve().parent
HARNESS = BENCH_DIR / "box2d_v3_harness.c"
DEFAULT_BUILD_ROOT = BENCH_DIR / "build" / "box2d-v3"
LIBRARY_NAME = "libbox2d_v3_harness.so"

CMAKE_OPTIONS = (
    "-DCMAKE_BUILD_TYPE=Release",
    "-DBUILD_SHARED_LIBS=OFF",
    "-DCMAKE_POSITION_INDEPENDENT_CODE=ON",  # the static library goes into our shared one
    "-DBOX2D_SAMPLES=OFF",
    "-DBOX2D_UNIT_TESTS=OFF",
    "-DBOX2D_BENCHMARKS=OFF",
    "-DBOX2D_DOCS=OFF",
)


class BuildError(RuntimeError):
    """Box2D v3 or the harness could not be built; the message says which step failed."""


@dataclass(frozen=True)
class V3Build:
    """A built harness library and what it was built from."""

    source: Path  # the Box2D v3 source tree
    commit: str  # its git commit (full hash), or "unknown" outside a git checkout
    describe: str  # `git describe --tags --always --dirty`, or "unknown"
    library: Path  # the shared library to load
    compiler: str  # the C compiler's first --version line

    def label(self) -> str:
        """One line for RESULTS.md: the commit and how it was built."""
        return (
            f"erincatto/box2d {self.commit[:8]} ({self.describe}), CMake Release, default SIMD "
            f"(SSE2 on x86-64), static library linked into the ctypes harness; {self.compiler}"
        )


def _run(cmd: list[str], what: str, log_path: Path, cwd: Path | None = None) -> str:
    try:
        p = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, check=False)
    except OSError as exc:
        raise BuildError(f"{what}: could not run {cmd[0]!r} ({exc})") from None
    with open(log_path, "a") as log:
        log.write(f"$ {' '.join(cmd)}\n{p.stdout}\n{p.stderr}\n")
    if p.returncode != 0:
        tail = (p.stderr.strip() or p.stdout.strip()).splitlines()[-1:] or ["no output"]
        raise BuildError(f"{what} failed (exit {p.returncode}): {tail[0]} (full log: {log_path})")
    return p.stdout


def _git(source: Path, *args: str) -> str:
    try:
        p = subprocess.run(["git", "-C", str(source), *args], capture_output=True, text=True, check=False)
    except OSError:
        return "unknown"
    return p.stdout.strip() if p.returncode == 0 and p.stdout.strip() else "unknown"


def cmake_version(source: Path) -> str:
    """The VERSION of ``project(box2d ...)`` in the tree's CMakeLists.txt, or "unknown"."""
    text = (source / "CMakeLists.txt").read_text(errors="replace")
    found = re.search(r"project\s*\(\s*box2d\b[^)]*?\bVERSION\s+([0-9][0-9.]*)", text, re.IGNORECASE)
    return found.group(1) if found else "unknown"


def check_source(source: Path) -> Path:
    """The resolved source tree, or BuildError if it does not look like Box2D v3."""
    source = Path(source).expanduser().resolve()
    if not (source / "CMakeLists.txt").is_file() or not (source / "include" / "box2d" / "box2d.h").is_file():
        raise BuildError(
            f"--box2d-v3 {source}: not a Box2D v3 source tree (expected CMakeLists.txt and include/box2d/box2d.h)"
        )
    if not (source / "include" / "box2d" / "types.h").is_file() or "b2WorldDef" not in (
        source / "include" / "box2d" / "types.h"
    ).read_text(errors="replace"):
        raise BuildError(
            f"--box2d-v3 {source}: include/box2d/types.h has no b2WorldDef: this looks like Box2D 2.x, not v3"
        )
    return source


def build(source: Path, build_root: Path = DEFAULT_BUILD_ROOT, jobs: int = 2, log=print) -> V3Build:
    """Build (or bring up to date) Box2D v3 from ``source`` and the harness library.

    Raises BuildError with a one-line reason when a step fails.
    """
    source = check_source(source)
    for tool in ("cmake",):
        if shutil.which(tool) is None:
            raise BuildError(f"{tool} not found on PATH: it is needed to build Box2D v3")
    cc = os.environ.get("CC", "cc")
    if shutil.which(cc) is None:
        raise BuildError(f"C compiler {cc!r} not found (set CC)")
    tree = hashlib.sha1(str(source).encode()).hexdigest()[:10]
    out = Path(build_root) / f"{source.name}-{tree}"
    cmake_dir = out / "cmake"
    out.mkdir(parents=True, exist_ok=True)
    log_path = out / "build.log"
    log_path.write_text("")
    if not (cmake_dir / "CMakeCache.txt").is_file():
        log(f"Box2D v3: configuring {source} in {cmake_dir}")
    _run(["cmake", "-S", str(source), "-B", str(cmake_dir), *CMAKE_OPTIONS], "cmake configure", log_path)
    log("Box2D v3: building the library (the first build takes about a minute)")
    _run(["cmake", "--build", str(cmake_dir), "--target", "box2d", "-j", str(jobs)], "cmake build", log_path)
    static = [p for p in cmake_dir.rglob("libbox2d*.a")]
    if len(static) != 1:
        raise BuildError(f"expected one libbox2d*.a under {cmake_dir}, found {len(static)}")
    library = out / LIBRARY_NAME
    newest = max(static[0].stat().st_mtime, HARNESS.stat().st_mtime)
    if not library.is_file() or library.stat().st_mtime < newest:
        _run(
            [
                cc,
                "-O2",
                "-fPIC",
                "-shared",
                "-Wall",
                "-Wextra",
                "-std=gnu17",
                "-I",
                str(source / "include"),
                str(HARNESS),
                str(static[0]),
                "-lm",
                "-o",
                str(library),
            ],
            "compiling the harness",
            log_path,
        )
    version = _run([cc, "--version"], "the compiler's version", log_path).splitlines()
    commit = _git(source, "rev-parse", "HEAD")
    describe = _git(source, "describe", "--tags", "--always", "--dirty")
    if describe == "unknown":  # a tree without its .git: at least the version its CMakeLists.txt declares
        describe = f"CMake project version {cmake_version(source)}, not a git checkout"
    return V3Build(source, commit, describe, library, version[0] if version else cc)
