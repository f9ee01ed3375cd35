"""Two checkouts of phys2d timed in alternating processes: the ratio of their time per step.

    python benchmarks/alternate.py /path/to/other/checkout                # this checkout / the other
    python benchmarks/alternate.py OTHER --rounds 6 --scenes stack10 pyr20 pyr40 --responders pgs soft

Each round runs ``benchmarks/min_times.py`` (this checkout's script) once with ``PYTHONPATH`` set
to this checkout and once to the other, in turn (the order swapped every round), each in a fresh
process; a process gives every scene's least CPU time per step over its repeats. A drift of the
machine's speed then weighs on both alike. Reported per scene and responder: each checkout's
least time over the rounds, the ratio of those, and the median and range of the ratios taken
within each round. Both checkouts' kernels must be compiled (run each once first): the first
round's figures are not thrown away.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent.parent


def one_run(checkout: Path, args: argparse.Namespace) -> dict[str, float]:
    """{scene/responder: µs per step} of one process of min_times.py importing ``checkout``."""
    command = [sys.executable, str(HERE / "benchmarks" / "min_times.py"), "--repeats", str(args.repeats)]
    command += ["--scenes", *args.scenes, "--responders", *args.responders]
    env = {**os.environ, "PYTHONPATH": str(checkout)}
    out = subprocess.run(command, env=env, capture_output=True, text=True, check=True, cwd=checkout).stdout
    return {key: float(value) for key, value in (item.split("=") for item in out.split())}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("other", type=Path, help="the other checkout (a git worktree of the commit compared)")
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--repeats", type=int, default=15)
    p.add_argument("--scenes", nargs="+", default=["stack10", "pyr20", "pyr40"])
    p.add_argument("--responders", nargs="+", default=["pgs", "block", "soft"])
    args = p.parse_args()
    times: dict[str, list[tuple[float, float]]] = {}
    for r in range(args.rounds):
        order = (HERE, args.other) if r % 2 == 0 else (args.other, HERE)
        got = {path: one_run(path, args) for path in order}
        for key in got[HERE]:
            times.setdefault(key, []).append((got[HERE][key], got[args.other][key]))
        print(f"round {r + 1}: load {os.getloadavg()[0]:.2f}", file=sys.stderr, flush=True)
    print("| scene/responder | this µs | other µs | min / min | median of round ratios (range) |")
    print("| --- | ---: | ---: | ---: | ---: |")
    for key, pairs in times.items():
        mine, theirs = min(a for a, _ in pairs), min(b for _, b in pairs)
        ratios = [a / b for a, b in pairs]
        spread = f"{min(ratios):.3f}-{max(ratios):.3f}"
        print(
            f"| {key} | {mine:.1f} | {theirs:.1f} | {mine / theirs:.3f} | {statistics.median(ratios):.3f} ({spread}) |"
        )


if __name__ == "__main__":
    main()
