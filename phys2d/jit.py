"""How phys2d compiles its kernels: numba's ``njit``, with numpy's error model.

Every kernel of the engine is decorated with this ``njit`` (``@njit(cache=True)``, as with
numba's own). The one setting it adds, ``error_model="numpy"``: a float divided by zero is
+-inf or NaN, as in numpy, where numba's default (Python's model) would raise
ZeroDivisionError. Why:

- The step refuses a non-finite result anyway: ``after_solve`` checks lambda, the residuals
  and the velocities (NOT_FINITE, TOO_FAST) and the world undoes the step, naming the bodies.
  No division of the engine's divides by zero on a state it accepts (h, dt, A_kk and the
  masses are checked to be positive, or tested before they divide).
- Under Python's model every division carries a path that raises. A kernel holds a
  reference (a count numba keeps with an atomic add) on each array it reads from a record
  or is handed; numba drops the pair of counts around a function's body only when no path
  leaves it by raising. With the raising paths gone, the soft step's and the block solver's
  row loops pay no reference counts (benchmarks/SMALL.md has the figures).

With ``NUMBA_DISABLE_JIT=1`` the kernels run as plain Python, where a division by zero would
raise; on the states the engine accepts none happens, so the results are the same.
"""

from __future__ import annotations

from typing import Any

import numba


def njit(*args: Any, **options: Any) -> Any:
    """``numba.njit`` with ``error_model="numpy"`` unless told otherwise; used as numba's is:
    ``@njit``, ``@njit(cache=True)``, ``@njit(cache=True, inline="always")``."""
    options.setdefault("error_model", "numpy")
    return numba.njit(*args, **options)
