"""Hypothesis profiles for the property tests.

    ci        the default: hypothesis's own 100 examples per property (unless a test sets
              fewer), so the whole suite runs in minutes on 2 cores; derandomized, so a CI
              run is reproducible
    thorough  many examples and a fresh random seed each run, for hunting bugs:
              PHYS2D_HYPOTHESIS_PROFILE=thorough python -m pytest tests/test_prop_*.py
    quick     a handful of examples, for runs with NUMBA_DISABLE_JIT=1 (the kernels as
              plain Python, e.g. to measure their line coverage)

deadline=None throughout: numba compiles each kernel on its first call, which would
otherwise make the first example of a property look slow.
"""

from __future__ import annotations

import os

import pytest
from hypothesis import HealthCheck, settings

# one process compiles: a child compiling ahead (phys2d.pipeline.ahead) would only race the tests' own
# compiles on a cold cache; tests/test_ahead.py turns it on where it is the subject
os.environ.setdefault("PHYS2D_COMPILE_AHEAD", "0")
# numba's OpenMP threads sleep while they wait instead of spinning: pytest-xdist runs a test per core, so
# a world on 2 threads shares its cores with the other worker, and a spinning thread takes the core the
# thread it waits for needs (benchmarks/TESTS.md has the figures). The bits do not depend on it.
os.environ.setdefault("OMP_WAIT_POLICY", "passive")
# the tests' child processes (the CLI as typed, the lessons, the sweeps' workers: about a hundred) keep
# phys2d's bytecode beside numba's cache in its __pycache__: with PYTHONDONTWRITEBYTECODE set, as on
# machines built to keep no .pyc, each child would compile phys2d's sources again (benchmarks/TESTS.md)
os.environ.pop("PYTHONDONTWRITEBYTECODE", None)

_COMMON = dict(deadline=None, print_blob=True, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

settings.register_profile("ci", max_examples=100, derandomize=True, **_COMMON)
settings.register_profile("thorough", max_examples=400, **_COMMON)
settings.register_profile("quick", max_examples=10, derandomize=True, **_COMMON)
settings.load_profile(os.environ.get("PHYS2D_HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture(scope="session")
def fresh_cache_compiles(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """What a fresh process compiles on a fresh numba cache (``tests/fresh_cache.py``), run once
    for the tests that ask: mark them ``xdist_group("fresh_cache")`` so one worker runs them all."""
    from tests.fresh_cache import compiles_on_a_fresh_cache

    return compiles_on_a_fresh_cache(tmp_path_factory.mktemp("fresh_numba_cache"))
