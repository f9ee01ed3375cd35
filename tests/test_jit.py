"""Every kernel is compiled by ``phys2d.jit.njit``, with numpy's error model: a division by zero
gives inf or NaN (which the step refuses) instead of a path that raises, so numba can drop the
reference counts of the arrays a kernel reads (``phys2d/jit.py``)."""

from __future__ import annotations

import ast
import math
import sys
from pathlib import Path

import pytest
from numba import config
from numba.core.registry import CPUDispatcher

import phys2d
from phys2d.jit import njit

PACKAGE = Path(phys2d.__file__).resolve().parent
jit_only = pytest.mark.skipif(config.DISABLE_JIT, reason="NUMBA_DISABLE_JIT: the kernels are plain Python")


def test_no_module_but_jit_py_takes_numba_s_own_njit() -> None:
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if path.name == "jit.py":
            continue
        where = path.relative_to(PACKAGE)
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module == "numba":
                found += [f"{where}: from numba import njit" for a in node.names if a.name == "njit"]
            numba_attr = isinstance(node, ast.Attribute) and getattr(node.value, "id", "") == "numba"
            if numba_attr and node.attr in ("njit", "jit"):
                found.append(f"{where}: numba.{node.attr}")
    assert found == []


@jit_only
def test_every_kernel_of_the_tick_has_numpy_s_error_model() -> None:
    w = phys2d.scenes.vertical_stack(3, responder=phys2d.SoftStep())
    w.step(1 / 60)  # (loads the tick and what it calls)
    modules = [m for name, m in list(sys.modules.items()) if name.startswith("phys2d") and m is not None]
    dispatchers = {id(d): d for m in modules for d in vars(m).values() if isinstance(d, CPUDispatcher)}
    assert len(dispatchers) > 50
    models = {d.__qualname__: d.targetoptions.get("error_model") for d in dispatchers.values()}
    assert {name: model for name, model in models.items() if model != "numpy"} == {}


@jit_only
def test_a_division_by_zero_in_a_kernel_gives_inf_or_nan() -> None:
    divide = njit(lambda a, b: a / b)
    assert divide(1.0, 0.0) == math.inf
    assert divide(-1.0, 0.0) == -math.inf
    assert math.isnan(divide(0.0, 0.0))
