"""Kernels compiled ahead (contin.app.compile_ahead): which modules a run hands to a second process, the child
itself, and a cold run with it equal to one without it."""

from __future__ import annotations

import json
import os
import pickle
import subprocess
import sys
import types
from pathlib import Path

import pytest

from contin.analyses.frequency_response import FrequencyResponse
from contin.app import compile_ahead
from contin.scene.build import build_model
from contin.scene.parse import load_scene
from contin.util import compile_ahead as registry

SCENES = Path(__file__).resolve().parents[2] / "scenes"


def _plan(name: str, **analysis):
    scene = load_scene(SCENES / name)
    scene.data["analysis"].update(analysis)
    return scene, scene_plan(scene)


def scene_plan(scene):
    return FrequencyResponse().plan(scene, build_model(scene))


class _Kernel:
    def __init__(self, index):
        self._cache = types.SimpleNamespace(_cache_file=types.SimpleNamespace(_index_path=str(index)))


def test_pending_names_the_modules_whose_kernels_have_no_cache_index(tmp_path):
    (tmp_path / "cached.nbi").write_bytes(b"")
    cached = types.SimpleNamespace(__name__="mod_cached", run=_Kernel(tmp_path / "cached.nbi"))
    cold = types.SimpleNamespace(__name__="mod_cold", run=_Kernel(tmp_path / "missing.nbi"))
    nocache = types.SimpleNamespace(__name__="mod_nocache", run=object())  # compiled without disk cache
    prob = types.SimpleNamespace(kernels=lambda: [(cached, "run"), (cold, "run"), (nocache, "run"), (cold, "run")])
    assert compile_ahead.pending([(prob, 1.0), (prob, 2.0)]) == ["mod_cold"]


def test_only_starts_that_may_integrate_are_compiled_ahead():
    _, plan = _plan("impact_oscillator.yaml")  # auto: harmonic balance, then shooting past the grazing point
    problems = FrequencyResponse().compile_ahead(plan)
    assert [lam for _, lam in problems] == [0.5]
    assert [f for _, f in problems[0][0].kernels()] == ["integrate", "flow"]
    _, plan = _plan("impact_oscillator.yaml", method="hb")
    assert FrequencyResponse().compile_ahead(plan) == []


def test_no_child_when_switched_off_or_nothing_is_missing(monkeypatch):
    scene, plan = _plan("impact_oscillator.yaml")
    monkeypatch.setenv(compile_ahead.ENV, "0")
    monkeypatch.setattr(compile_ahead, "pending", lambda problems: pytest.fail("asked while switched off"))
    assert compile_ahead.start(scene, FrequencyResponse(), plan) == []
    monkeypatch.delenv(compile_ahead.ENV)
    monkeypatch.setattr(compile_ahead, "pending", lambda problems: [])
    assert compile_ahead.start(scene, FrequencyResponse(), plan) == []
    assert registry.active() is None


def test_the_child_compiles_and_reports_each_module_of_the_scene():
    scene, plan = _plan("impact_oscillator.yaml")
    modules = [m.__name__ for m, _ in FrequencyResponse().compile_ahead(plan)[0][0].kernels()]
    cmd = [sys.executable, "-P" if sys.version_info >= (3, 11) else "-I", "-m", "contin.app.compile_ahead"]
    done = subprocess.run(cmd, input=pickle.dumps(scene), capture_output=True, timeout=600, cwd="/")
    assert done.returncode == 0, done.stderr.decode()[-2000:]
    assert sorted(done.stdout.decode().split()) == sorted(modules)


@pytest.mark.slow
def test_a_cold_run_with_its_kernels_compiled_ahead_equals_one_without(tmp_path):
    """Two processes on two empty caches: the run with the child waits for it and writes the same rows as the
    run without."""
    rows = {}
    for ahead in ("1", "0"):
        env = dict(os.environ, CONTIN_CACHE_DIR=str(tmp_path / f"cache{ahead}"), **{compile_ahead.ENV: ahead})
        out = tmp_path / f"out{ahead}"
        cmd = [sys.executable, "-m", "contin", "run", str(SCENES / "impact_oscillator.yaml"), "-o", str(out), "-q",
               "--set", "analysis.range=[0.8, 0.9]", "--set", "output.plots=false"]
        done = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=900)
        assert done.returncode == 0, done.stderr[-2000:]
        summary = json.loads((out / "summary.json").read_text())
        assert summary["status"] == "complete"
        assert ("compile_ahead_wait" in summary["timings"]) == (ahead == "1")
        rows[ahead] = (out / "branches.csv").read_text()
    assert rows["1"] == rows["0"]
