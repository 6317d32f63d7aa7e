"""The persistent worker process behind isolated backends."""

import os
import signal
from multiprocessing.connection import Connection

import pytest

from solvers._worker import Worker, WorkerDied, WorkerError, describe_exit, wait_for_workers


def test_worker_runs_functions_and_survives_a_crash(tmp_path):
    worker = Worker("test")
    try:
        assert worker.call("os:getpid") != os.getpid()
        first = worker.call("os:getpid")
        assert worker.call("os:getpid") == first  # persistent
        with pytest.raises(WorkerError, match="(?s)test worker: .*ZeroDivisionError"):
            worker.call("operator:truediv", 1, 0)
        assert worker.call("os:getpid") == first  # an exception does not kill it
        with pytest.raises(WorkerDied, match=r"test worker process \d+ died \(exit code 3\)"):
            worker.call("os:_exit", 3)
        assert worker.call("os:getpid") != first  # restarted
    finally:
        worker.stop()


def test_library_output_on_stdout_does_not_corrupt_replies():
    worker = Worker("noisy")
    try:
        assert worker.call("builtins:print", "noise on fd 1") is None
        assert worker.call("operator:add", 2, 3) == 5
    finally:
        worker.stop()


def test_timeout_kills_a_hung_worker():
    worker = Worker("slow")
    try:
        with pytest.raises(WorkerError, match="no reply within"):
            worker.call("time:sleep", 30, timeout=0.5)
        assert worker.call("operator:add", 1, 1) == 2
    finally:
        worker.stop()


def test_calls_sent_ahead_are_answered_in_order_and_a_killed_worker_says_how_it_died():
    workers = [Worker("first", log=False), Worker("second", log=False)]
    try:
        for number, worker in enumerate(workers):
            worker.send("operator:add", number, 10)
            worker.send("operator:mul", number, 10)
        assert workers[0].pending == 2
        wait_for_workers(workers, timeout=30)
        assert [worker.receive() for worker in workers] == [10, 11]
        assert [worker.receive() for worker in workers] == [0, 10]
        assert not any(worker.ready() for worker in workers)

        workers[1].send("time:sleep", 30)
        os.kill(workers[1].pid, signal.SIGKILL)
        wait_for_workers(workers, timeout=30)
        assert workers[1].ready() and not workers[0].ready()
        with pytest.raises(WorkerDied) as died:
            workers[1].receive()
        assert died.value.exit == "killed by SIGKILL" and workers[1].pid is None
    finally:
        for worker in workers:
            worker.stop()


def test_an_unpicklable_result_is_an_error_and_the_worker_goes_on():
    worker = Worker("lambda")
    try:
        with pytest.raises(WorkerError, match="(?s)lambda worker: .*pickle"):
            worker.call("threading:Lock")
        assert worker.call("operator:add", 1, 2) == 3
    finally:
        worker.stop()


def test_an_interrupted_call_stops_the_worker_so_that_no_late_reply_answers_the_next_call(monkeypatch):
    worker = Worker("interrupted")
    try:
        first = worker.call("os:getpid")
        with monkeypatch.context() as patched:
            patched.setattr(Connection, "poll", _interrupt)
            with pytest.raises(KeyboardInterrupt):
                worker.call("operator:add", 1, 2)
        assert worker.pid is None
        assert worker.call("operator:add", 2, 2) == 4 and worker.call("os:getpid") != first
    finally:
        worker.stop()


def _interrupt(*args: object) -> bool:
    raise KeyboardInterrupt


def test_describe_exit_names_the_signal():
    assert describe_exit(-signal.SIGSEGV) == "killed by SIGSEGV"
    assert describe_exit(-200) == "killed by signal 200"
    assert describe_exit(3) == "exit code 3"
