"""numba's reference counts a step makes, counted: calls to NRT_incref and NRT_decref per step, by caller.

    python benchmarks/refcounts.py --responder soft --steps 100

Each count is an atomic add (benchmarks/SMALL.md, "Arguments held across a call"). The script runs
itself under ``valgrind --tool=callgrind`` (valgrind must be installed; the run takes a few
minutes, most of it importing numba under valgrind), with the collection switched on only for
the counted steps of ``vertical_stack(10)`` (or ``--scene``), after ``--settle`` steps. numba's
code has no symbols valgrind can see, so the child writes each kernel function's address and size
(from its object code's symbols, as ``perf_kernels.py`` does; each library holds its own copy of
``NRT_incref``/``NRT_decref``) and numba's runtime's; callgrind keeps the address of each call
(``--dump-instr=yes``), and a count goes to the function whose code holds the call (a decrement a
destructor makes counts too, under the destructor's address when it has no symbol). A kernel
numba or LLVM inlined into its caller counts in the caller. The kernels must be in numba's cache
(run the scene once first): those compiled under valgrind are not named.
``--checkout PATH`` counts another checkout's phys2d (both on their own warm numba cache).
"""

from __future__ import annotations

import argparse
import bisect
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
    lines = {f"{rtsys.library.get_pointer_to_function(name):x} 0 {name}" for name in REFCOUNTS}
    lines.update(f"{address:x} {size:x} {symbol}" for address, size, symbol in perf_kernels.kernel_functions())
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


class Functions:
    """The kernels' functions by address (from the child's map): which one holds an address."""

    def __init__(self, address_map: Path) -> None:
        spans = []
        for line in address_map.read_text().splitlines():
            address, size, name = line.split(" ", 2)
            spans.append((int(address, 16), int(size, 16), name))
        spans.sort()
        self.refcounts = {a: name for a, _, name in spans if name in REFCOUNTS}  # every library's copy
        self.spans = [span for span in spans if span[1] > 0]
        self.starts = [a for a, _, _ in self.spans]

    def holding(self, address: int) -> str:
        """module.function of the kernel whose code holds ``address``, else the address."""
        i = bisect.bisect_right(self.starts, address) - 1
        if i >= 0 and address < self.spans[i][0] + self.spans[i][1]:
            return short(self.spans[i][2])
        return hex(address)


def counts(out: Path, functions: Functions, steps: int) -> tuple[collections.Counter, collections.Counter]:
    """(calls per step to each of REFCOUNTS, and per (caller, callee)) from a callgrind dump made
    with ``--dump-instr=yes``: a call's cost line starts with the address of the call (absolute,
    or relative to the line before)."""
    ids: dict[str, str] = {}
    total: collections.Counter = collections.Counter()
    by_caller: collections.Counter = collections.Counter()
    callee: str | None = None
    calls = 0
    position = 0
    for line in out.read_text().splitlines():
        if line.startswith(("fn=", "cfn=")):
            m = re.match(r"c?fn=\((\d+)\)(?: (.*))?", line)
            if m is None:
                continue
            if m.group(2):
                ids[m.group(1)] = m.group(2)
            if line.startswith("cfn="):
                name = ids.get(m.group(1), "")
                a = re.match(r"0x0*([0-9a-f]+)", name)
                callee = functions.refcounts.get(int(a.group(1), 16)) if a else (name if name in REFCOUNTS else None)
            continue
        if line.startswith("calls="):
            calls = int(line[6:].split()[0])
            continue
        m = re.match(r"(0x[0-9a-f]+|[+-]\d+|\*)\s", line)
        if m is None:
            continue
        token = m.group(1)
        if token.startswith("0x"):
            position = int(token, 16)
        elif token != "*":
            position += int(token)
        if calls:
            if callee is not None:
                total[callee] += calls / steps
                by_caller[(functions.holding(position), callee)] += calls / steps
            calls, callee = 0, None
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
        command = ["valgrind", "--tool=callgrind", "--instr-atstart=no", "--dump-instr=yes"]
        command += [f"--callgrind-out-file={out}"]
        command += [sys.executable, __file__, "--child", "--map", str(address_map)]
        command += ["--responder", args.responder, "--scene", args.scene]
        command += ["--settle", str(args.settle), "--steps", str(args.steps)]
        command += ["--checkout", args.checkout] if args.checkout else []
        env = {**os.environ, "PHYS2D_COMPILE_AHEAD": "0"}
        subprocess.run(command, env=env, check=True, capture_output=True)
        dumps = sorted(Path(tmp).glob("callgrind.out.*"))  # the counted steps' (-d), not the exit's
        total, by_caller = counts(dumps[0], Functions(address_map), args.steps)
    where = args.checkout or HERE.parent
    print(f"{where}: {args.scene}(10), {args.responder}, calls per step over {args.steps} steps:")
    for name in REFCOUNTS:
        print(f"  {name}: {total[name]:.0f}")
    print("by caller:")
    for (caller, callee), n in by_caller.most_common(args.top):
        print(f"  {n:6.1f}  {caller} -> {callee}")


if __name__ == "__main__":
    main()
