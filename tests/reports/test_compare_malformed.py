"""``harness compare`` of pytest-benchmark JSON files that are not what they claim: one line naming the file
and the benchmark, never a TypeError from deep inside the comparison."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from harness.cli import cli


@pytest.mark.parametrize(
    ("document", "message"),
    [
        ({"benchmarks": 5}, "not a pytest-benchmark JSON file (no 'benchmarks' list)"),
        ([1, 2], "not a pytest-benchmark JSON file (no 'benchmarks' list)"),
        ({"benchmarks": [5]}, "benchmark 1 is not an object"),
        ({"benchmarks": [{"stats": {"median": 1}}]}, "benchmark 1 has no name"),
        ({"benchmarks": [{"name": ["a"]}]}, "benchmark 1 has no name"),
        ({"benchmarks": [{"name": "a", "stats": 5}]}, "its 'stats' and 'extra_info' must be objects"),
        ({"benchmarks": [{"name": "a", "extra_info": [1]}]}, "its 'stats' and 'extra_info' must be objects"),
        ({"benchmarks": [{"name": "a", "stats": {"median": "fast"}}]}, "its median 'fast' is not a number"),
        ({"benchmarks": [{"name": "a", "stats": {"median": [1]}}]}, "its median [1] is not a number"),
    ],
)
def test_a_malformed_benchmark_file_is_one_line(tmp_path, document, message) -> None:
    (tmp_path / "a.json").write_text(json.dumps(document))
    (tmp_path / "b.json").write_text('{"benchmarks": []}')
    ran = CliRunner().invoke(cli, ["compare", str(tmp_path / "a.json"), str(tmp_path / "b.json")])
    assert ran.exit_code == 2 and message in ran.output, ran.output
    assert len(ran.output.strip().splitlines()) == 1


def test_a_benchmark_file_nested_too_deeply_is_one_line(tmp_path) -> None:
    (tmp_path / "a.json").write_text("[" * 100_000 + "]" * 100_000)
    (tmp_path / "b.json").write_text('{"benchmarks": []}')
    ran = CliRunner().invoke(cli, ["compare", str(tmp_path / "a.json"), str(tmp_path / "b.json")])
    assert ran.exit_code == 2 and "nested too deeply" in ran.output, ran.output
