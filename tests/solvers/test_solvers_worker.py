"""The persistent worker process behind isolated backends."""

import os

import pytest

from solvers._worker import Worker, WorkerError


def test_worker_runs_functions_and_survives_a_crash(tmp_path):
    worker = Worker("test")
    try:
        assert worker.call("os:getpid") != os.getpid()
        first = worker.call("os:getpid")
        assert worker.call("os:getpid") == first  # persistent
        with pytest.raises(WorkerError, match="(?s)test worker: .*ZeroDivisionError"):
            worker.call("operator:truediv", 1, 0)
        assert worker.call("os:getpid") == first  # an exception does not kill it
        with pytest.raises(WorkerError, match="worker process failed"):
            worker.call("os:_exit", 3)
        assert worker.call("os:getpid") != first  # restarted
    finally:
        worker.close()


def test_library_output_on_stdout_does_not_corrupt_replies():
    worker = Worker("noisy")
    try:
        assert worker.call("builtins:print", "noise on fd 1") is None
        assert worker.call("operator:add", 2, 3) == 5
    finally:
        worker.close()


def test_timeout_kills_a_hung_worker():
    worker = Worker("slow")
    try:
        with pytest.raises(WorkerError, match="no reply within"):
            worker.call("time:sleep", 30, timeout=0.5)
        assert worker.call("operator:add", 1, 1) == 2
    finally:
        worker.close()
