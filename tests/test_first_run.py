"""The first run's estimate (``phys2d.first_run``): from the last first run kept beside the cache
when there is one, else from this machine's pace; never a figure written for another machine."""

from __future__ import annotations

import json

import pytest

from phys2d import first_run


@pytest.fixture
def kept(tmp_path, monkeypatch):
    record = tmp_path / first_run.FILE
    monkeypatch.setattr(first_run, "_record_file", lambda: record)
    twice_as_slow = 2 * first_run.REFERENCE_PACE  # a machine twice as slow as the reference's
    monkeypatch.setattr(first_run, "cpu_pace", lambda repeats=10: twice_as_slow)
    return record


def test_without_a_record_the_estimate_scales_with_the_pace(kept):
    """Twice the reference's pace: twice its time, for each responder and core count."""
    assert first_run.estimate(["pgs"], 2) == pytest.approx(2 * first_run.REFERENCE["pgs"])
    assert first_run.estimate(["soft-step"], 1) == pytest.approx(2 * first_run.REFERENCE_CPU["soft-step"])
    assert first_run.estimate(["pgs", "soft-step"], 2) == pytest.approx(2 * first_run.REFERENCE["soft-step"])


def test_a_kept_first_run_sets_the_next_estimate(kept):
    """A first run of pgs that took 90 s here at this pace: the next pgs estimate is 90 s, the soft
    step's the reference's ratio of it; a damaged record falls back on the pace."""
    first_run.remember(["pgs"], 90.0, 2)
    assert json.loads(kept.read_text())["seconds"] == 90.0
    assert first_run.estimate(["pgs"], 2) == pytest.approx(90.0)
    ratio = first_run.REFERENCE["soft-step"] / first_run.REFERENCE["pgs"]
    assert first_run.estimate(["soft-step"], 2) == pytest.approx(90.0 * ratio)
    kept.write_text("{not json")
    assert first_run.estimate(["pgs"], 2) == pytest.approx(2 * first_run.REFERENCE["pgs"])


def test_the_pace_takes_milliseconds():
    assert 0.0 < first_run.cpu_pace() < 0.05
