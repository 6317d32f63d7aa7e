"""Quality figures do not depend on the CPU's SIMD kernels: a run with numpy's AVX-512 kernels switched
off compares clean against a default run (the drift that once failed CI on another machine)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from reports import compare

#: What numpy dispatches on a machine with AVX-512 and what switching it off takes (numpy >= 2.0 names).
_AVX512 = "X86_V4 AVX512_ICL AVX512_SPR"


def _has_avx512() -> bool:
    from numpy._core._multiarray_umath import __cpu_features__

    return bool(__cpu_features__.get("X86_V4"))


def _run(out: Path, **environment: str) -> None:
    grid = ["--rigs", "tiny,arkit52", "--solvers", "cpsat,greedy", "--out", str(out), "--quiet"]
    command = [sys.executable, "-c", "from harness.cli import main; main()", "run", *grid]
    done = subprocess.run(command, env={**os.environ, **environment}, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


@pytest.mark.skipif(not _has_avx512(), reason="this CPU has no AVX-512 (X86_V4): nothing to switch off")
def test_quality_figures_hold_without_the_avx512_kernels(tmp_path) -> None:
    _run(tmp_path / "default")
    _run(tmp_path / "plain", NPY_DISABLE_CPU_FEATURES=_AVX512)
    comparison = compare(tmp_path / "default", tmp_path / "plain")
    quality = [change for change in comparison.changes if change.kind == "quality"]
    assert any(change.metric.startswith("RMS") for change in quality)
    assert not comparison.regressions(), comparison.regressions()
