"""numba's reference counts a step makes, counted: calls to NRT_incref and NRT_decref per step, by caller.

    python benchmarks/refcounts.py --responder soft --steps 100

Each count is an atomic add (benchmarks/SMALL.md, "Arguments held across a call"). The script runs
itself under ``valgrind --tool=callgrind`` (valgrind must be installed; the run takes a few
minutes, most of it importing numba under valgrind), with the collection switched on only for
the counted steps of ``vertical_stack(10)`` (or ``--scene``), after ``--settle`` steps. numba's
code has no symbols valgrind can see, so the child writes each kernel's address (from its object
code's symbols, as ``perf_kernels.py`` does) and numba's runtime's ``NRT_incref``/``NRT_decref``;
the counts are read from callgrind's output with those names (a decrement a destructor makes
counts too). A kernel numba or LLVM inlined into its caller counts in the caller.
``--checkout PATH`` counts another checkout's phys2d (both on their own warm numba cache).
"""

from __future__ import annotations

import argparse
import collections
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
REFCOUNTS = ("NRT_incref", "NRT_decref")


def child(args: argparse.Namespace) -> None:
    """Under callgrind: settle, count the steps, write the address map."""
    sys.path.insert(0, str(HERE))
    import perf_kernels  # (keeps each library's object code, for its symbols; imports this checkout's phys2d)
    from numba.core.runtime import rtsys

    if args.checkout is not None:  # another checkout's phys2d, imported anew
        for name in [name for name in sys.modules if name.startswith("phys2d")]:
            del sys.modules[name]
        sys.path.insert(0, str(Path(args.checkout).resolve()))
    import phys2d

    responder = phys2d.SoftStep(substeps=4) if args.responder == "soft" else phys2d.PGS()
    w = getattr(phys2d.scenes, args.scene)(10, responder=responder)
    for _ in range(args.settle):
        w.step(1 / 60)

    def control(*flags: str) -> None:
        subprocess.run(["callgrind_control", *flags, str(os.getpid())], capture_output=True, check=False)

    control("-i", "on")
    for _ in range(args.steps):
        w.step(1 / 60)
    control("-d")
    control("-i", "off")
    lines = {f"{rtsys.library.get_pointer_to_function(name):x} {name}" for name in REFCOUNTS}
    lines.update(f"{address:x} {symbol}" for address, _, symbol in perf_kernels.kernel_functions())
    Path(args.map).write_text("\n".join(sorted(lines)) + "\n")


def short(symbol: str) -> str:
    """module.function of a numba-mangled symbol, else the symbol."""
    m = re.match(r"_ZN(?:7cpython)?((?:\d+[A-Za-z_]\w*?)+?)B\d+v\d+", symbol)
    if not m:
        return symbol[:60]
    parts, rest = [], m.group(1)
    while rest:
        n = re.match(r"\d+", rest)
        length, rest = int(n.group(0)), rest[n.end() :]
        parts.append(rest[:length])
        rest = rest[length:]
    return ".".join(parts[-2:])


def counts(out: Path, names: dict[int, str], steps: int) -> tuple[collections.Counter, collections.Counter]:
    """(calls per step to each of REFCOUNTS, and per (caller, callee)) from a callgrind dump."""
    ids: dict[str, str] = {}

    def name_of(token: str) -> str:
        m = re.match(r"\((\d+)\)(?: (.*))?", token)
        if m is None:
            return token
        if m.group(2):
            ids[m.group(1)] = m.group(2)
        raw = ids.get(m.group(1), token)
        a = re.match(r"0x0*([0-9a-f]+)", raw)
        return short(names.get(int(a.group(1), 16), raw)) if a else raw

    total: collections.Counter = collections.Counter()
    by_caller: collections.Counter = collections.Counter()
    caller = callee = ""
    for line in out.read_text().splitlines():
        if line.startswith("fn="):
            caller = name_of(line[3:])
        elif line.startswith("cfn="):
            callee = name_of(line[4:])
        elif line.startswith("calls=") and callee in REFCOUNTS:
            n = int(line[6:].split()[0])
            total[callee] += n / steps
            by_caller[(caller, callee)] += n / steps
    return total, by_caller


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--responder", choices=("pgs", "soft"), default="pgs")
    p.add_argument("--scene", default="vertical_stack", help="a phys2d.scenes function taking a size (10)")
    p.add_argument("--settle", type=int, default=60)
    p.add_argument("--steps", type=int, default=100)
    p.add_argument("--top", type=int, default=15)
    p.add_argument("--checkout", help="count another checkout's phys2d (a worktree of the commit compared)")
    p.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--map", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.child:
        child(args)
        return
    with tempfile.TemporaryDirectory() as tmp:
        out, address_map = Path(tmp) / "callgrind.out", Path(tmp) / "addresses"
        command = ["valgrind", "--tool=callgrind", "--instr-atstart=no", f"--callgrind-out-file={out}"]
        command += [sys.executable, __file__, "--child", "--map", str(address_map)]
        command += ["--responder", args.responder, "--scene", args.scene]
        command += ["--settle", str(args.settle), "--steps", str(args.steps)]
        command += ["--checkout", args.checkout] if args.checkout else []
        env = {**os.environ, "PHYS2D_COMPILE_AHEAD": "0"}
        subprocess.run(command, env=env, check=True, capture_output=True)
        names = {}
        for line in address_map.read_text().splitlines():
            address, name = line.split(" ", 1)
            names[int(address, 16)] = name
        dumps = sorted(Path(tmp).glob("callgrind.out.*"))
        total, by_caller = counts(dumps[0], names, args.steps)
    where = args.checkout or HERE.parent
    print(f"{where}: {args.scene}(10), {args.responder}, calls per step over {args.steps} steps:")
    for name in REFCOUNTS:
        print(f"  {name}: {total[name]:.0f}")
    print("by caller:")
    for (caller, callee), n in by_caller.most_common(args.top):
        print(f"  {n:6.1f}  {caller} -> {callee}")


if __name__ == "__main__":
    main()
