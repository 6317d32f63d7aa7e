"""`registry.BoundedMemo`, the one cache type (transfer set-ups, scans, fitted expressions, cell rigs)."""

from __future__ import annotations

import threading

from registry import BoundedMemo


def test_the_least_recently_used_value_goes_first():
    memo = BoundedMemo(2)
    memo.put("a", 1)
    memo.put("b", 2)
    assert memo.get("a") == 1  # "a" is now the most recent
    memo.put("c", 3)
    assert (memo.get("a"), memo.get("b"), memo.get("c"), len(memo)) == (1, None, 3, 2)
    memo.clear()
    assert len(memo) == 0 and memo.get("a") is None


def test_a_value_is_built_once_and_kept():
    memo, calls = BoundedMemo(4), []
    build = lambda: calls.append(1) or len(calls)  # noqa: E731
    assert memo.get_or_build("k", build) == 1
    assert memo.get_or_build("k", build) == 1 and calls == [1]
    assert BoundedMemo(0).size == 1  # a memo keeps at least one value


def test_threads_share_one_memo_without_losing_its_bound():
    memo = BoundedMemo(8)

    def fill(offset: int) -> None:
        for key in range(200):
            memo.get_or_build((offset, key), lambda key=key: key)

    threads = [threading.Thread(target=fill, args=(offset,)) for offset in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert len(memo) == 8
