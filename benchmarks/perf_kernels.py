"""Which numba kernel a step spends its time in: a scene under Linux ``perf``, kernels by name.

    perf record -F 4000 -o perf.data python benchmarks/perf_kernels.py --scene large_pyramid
    perf report -i perf.data --no-children --sort symbol

numba's compiled code has no symbols ``perf`` can see, so this script writes the map ``perf``
reads for code made at run time (``/tmp/perf-PID.map``, one line per function: start, size,
name) from the object code numba made or loaded from its cache. Each kernel then shows under
its mangled name (``...soft_contacts16soft_normal_rows...``); a kernel numba inlined into its
caller counts in the caller.

Only the timed steps are sampled when ``perf`` is given a control pipe, and the script the
same pipe (``--control``): the scene is built and settled with ``perf`` off, then the script
writes ``enable`` and, after the timed steps, ``disable``::

    mkfifo /tmp/ctl
    perf record -D -1 --control fifo:/tmp/ctl -F 4000 -o perf.data \\
        python benchmarks/perf_kernels.py --scene large_pyramid --control /tmp/ctl

``--scene`` is any of ``phys2d.scenes`` that needs no argument (``large_pyramid``,
``many_pyramids``, ...) or ``pyramid_N``; ``--responder`` is ``soft`` (``SoftStep(4)``) or
``pgs``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba.core.codegen as codegen

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))  # the phys2d of this checkout

_set_compiled_object = codegen.CPUCodeLibrary._set_compiled_object


def _keep_object(library: codegen.CPUCodeLibrary, value: bytes) -> None:
    """Keep each library's object code (numba drops it once it is loaded) for its symbols."""
    library._kept_object = value  # type: ignore[attr-defined]
    _set_compiled_object(library, value)


codegen.CPUCodeLibrary._set_compiled_object = _keep_object  # before phys2d compiles or loads a kernel

from numba.core.registry import CPUDispatcher  # noqa: E402

import phys2d  # noqa: E402


def symbols_of(obj: bytes) -> dict[str, tuple[int, int]]:
    """name -> (offset, size) of the functions defined in an ELF object (``nm``)."""
    with tempfile.NamedTemporaryFile(suffix=".o") as f:
        f.write(obj)
        f.flush()
        out = subprocess.run(["nm", "-S", "--defined-only", f.name], capture_output=True, text=True).stdout
    found = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 4 and parts[2] in "tTWw":
            found[parts[3]] = (int(parts[0], 16), int(parts[1], 16))
    return found


def kernel_functions() -> set[tuple[int, int, str]]:
    """(address, size, symbol) of every function in every phys2d kernel compiled or loaded so far.
    Each library's functions are placed from its entry point's address and its offset in the
    object."""
    found = set()
    seen = set()
    for name, module in list(sys.modules.items()):
        if not name.startswith("phys2d"):
            continue
        for dispatcher in list(vars(module).values()):
            if not isinstance(dispatcher, CPUDispatcher) or id(dispatcher) in seen:
                continue
            seen.add(id(dispatcher))
            for compiled in dispatcher.overloads.values():
                library, entry = compiled.library, compiled.fndesc.llvm_func_name
                obj = getattr(library, "_kept_object", None)
                address = library.get_pointer_to_function(entry)
                if obj is None or not address:
                    continue
                symbols = symbols_of(obj)
                if entry not in symbols:
                    continue
                base = address - symbols[entry][0]
                found.update((base + offset, size, symbol) for symbol, (offset, size) in symbols.items())
    return found


def write_perf_map() -> int:
    """Write /tmp/perf-PID.map for every phys2d kernel compiled or loaded so far
    (``kernel_functions``); returns the number of functions named."""
    lines = {f"{address:x} {size:x} {symbol}" for address, size, symbol in kernel_functions()}
    with open(f"/tmp/perf-{os.getpid()}.map", "w") as f:
        f.write("\n".join(sorted(lines)) + "\n")
    return len(lines)


def make_world(scene: str, responder: str) -> phys2d.World:
    """The scene with ``SoftStep(4)`` (soft) or ``PGS()`` (pgs)."""
    r = phys2d.PGS() if responder == "pgs" else phys2d.SoftStep(substeps=4)
    if scene.startswith("pyramid_"):
        return phys2d.scenes.pyramid(int(scene.split("_")[1]), responder=r)
    return getattr(phys2d.scenes, scene)(responder=r)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", default="large_pyramid")
    p.add_argument("--responder", choices=("soft", "pgs"), default="soft")
    p.add_argument("--threads", type=int, default=1, help="World.threads")
    p.add_argument("--settle", type=int, default=30, help="steps before the timed ones")
    p.add_argument("--steps", type=int, default=300, help="timed steps")
    p.add_argument("--control", default=None, metavar="FIFO", help="perf's control pipe (perf record --control)")
    args = p.parse_args(argv)
    w = make_world(args.scene, args.responder)
    w.threads = args.threads
    for _ in range(args.settle):
        w.step(1 / 60)
    if args.control:
        with open(args.control, "w") as ctl:
            ctl.write("enable\n")
    t0 = time.perf_counter()
    for _ in range(args.steps):
        w.step(1 / 60)
    elapsed = time.perf_counter() - t0
    if args.control:
        with open(args.control, "w") as ctl:
            ctl.write("disable\n")
    named = write_perf_map()
    print(f"{args.scene}, {args.responder}, {args.threads} thread(s): {elapsed / args.steps * 1e6:,.0f} us per step")
    print(f"/tmp/perf-{os.getpid()}.map: {named} functions named")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
