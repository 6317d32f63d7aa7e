"""`reports._gate`: an intended slow-down is accepted by a committed file naming its commit, case and
reason."""

from __future__ import annotations

import pytest

from registry import HarnessError
from reports._gate import accepted_for, read_accepted

BASE = "351111f61fd1f0c2bb0d0fbd5dbcd1d84aac4e32"
SLOW = "9131b0585d2e9b3a1c3b9f5d3a5e7f1d2c3b4a59"


def _file(tmp_path, text: str):
    path = tmp_path / "accepted-slowdowns.toml"
    path.write_text(text)
    return path


def test_an_entry_names_the_base_commit_the_cases_and_the_reason(tmp_path):
    entries = read_accepted(
        _file(
            tmp_path,
            '[[slowdown]]\nafter = "351111f"\ncase = "*/cpsat"\nreason = "proves its bounds"\n'
            "max_ratio = 2.0\n"
            '[[slowdown]]\ncommit = "9131b05"\ncase = "film/*"\nreason = "a finer mesh"\n',
        )
    )
    assert accepted_for("arkit52/big-eyes/cpsat", 1.8, BASE, [SLOW], entries).reason == "proves its bounds"
    assert accepted_for("arkit52/big-eyes/cpsat", 2.5, BASE, [SLOW], entries) is None  # beyond max_ratio
    assert accepted_for("arkit52/big-eyes/highs", 1.8, BASE, [SLOW], entries) is None  # another case
    assert accepted_for("arkit52/big-eyes/cpsat", 1.8, "0" * 40, [SLOW], entries) is None  # another base
    assert accepted_for("film/alien/highs", 3.0, "0" * 40, [SLOW], entries).reason == "a finer mesh"
    assert accepted_for("film/alien/highs", 3.0, "0" * 40, ["1" * 40], entries) is None  # not in the range


def test_no_file_accepts_nothing(tmp_path):
    assert read_accepted(tmp_path / "missing.toml") == []


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[[slowdown]\n", "not a TOML file"),
        ('gate = "off"\n', "expected only"),
        ('[[slowdown]]\nafter = "351111f"\ncase = "*"\n', "needs a case pattern and a reason"),
        ('[[slowdown]]\ncase = "*"\nreason = "x"\n', "exactly one of after"),
        ('[[slowdown]]\nafter = "3511"\ncase = "*"\nreason = "x"\n', "at least 7 hex digits"),
        ('[[slowdown]]\nafter = "351111f"\ncase = "*"\nreason = "x"\nmax_ratio = 0.5\n', "max_ratio"),
        ('[[slowdown]]\nafter = "351111f"\ncase = "*"\nreason = "x"\nwho = "me"\n', "keys are"),
    ],
)
def test_a_malformed_file_is_refused_naming_the_entry(tmp_path, text, message):
    with pytest.raises(HarnessError, match=message):
        read_accepted(_file(tmp_path, text))
