"""The GIL, progress, Ctrl-C and cancellation, and the mapping of the library's exceptions.

The long runs here (newton-cubic at 512, tens of seconds) are cancelled within a second or
two when the tests pass; they run to the end only when cancellation is broken. A Python
exception (Ctrl-C, or one raised by the callback) returns within a second even when the
library is slow to stop (the cancelled work then ends on its own); a cancellation asked for by
the caller (False, CancelToken) returns once the work has stopped, which on this shared machine
took 0.1 to 2.4 s.
"""

import os
import signal
import subprocess
import sys
import textwrap
import threading
import time

import pytest

import qjulia

LONG = dict(preset="newton-cubic", resolution=512)


def test_progress_reports_the_stages_in_order_on_the_calling_thread():
    calls = []

    def progress(stage, fraction):
        calls.append((stage, fraction, threading.get_ident()))

    m = qjulia.mesh(preset="classic-julia", resolution=64, progress=progress)
    assert calls, "the callback was never called"
    stages = [s for s, _, _ in calls]
    assert set(stages) == set(m.stats["timings"]) - {"total"}  # every stage, however short
    assert stages[0] == "estimate" and stages[-1] == "measure"
    first = sorted(set(stages), key=stages.index)
    assert all(stages.index(s) + stages[stages.index(s):].count(s) - 1 ==
               len(stages) - 1 - stages[::-1].index(s) for s in first), "a stage came back"
    assert all(0 <= f <= 1 for _, f, _ in calls)
    assert {t for _, _, t in calls} == {threading.get_ident()}


def test_a_callback_returning_false_cancels():
    started = []

    def progress(stage, fraction):
        if not started:
            started.append(time.monotonic())
            return True
        return time.monotonic() - started[0] < 0.3

    with pytest.raises(qjulia.Cancelled):
        qjulia.mesh(progress=progress, **LONG)
    assert started and time.monotonic() - started[0] < 0.3 + 5


def test_an_exception_in_the_callback_propagates_within_a_second():
    class Stop(Exception):
        pass

    def progress(stage, fraction):
        raise Stop(stage)

    t0 = time.monotonic()
    with pytest.raises(Stop, match="estimate"):  # the first stage
        qjulia.mesh(progress=progress, **LONG)
    assert time.monotonic() - t0 < 1


def test_other_python_threads_run_while_a_mesh_is_made():
    # The mesh runs in a thread without a callback and is cancelled by a token that the main
    # thread requests only after running Python code: with the GIL held during the work, that
    # code could not run before the (long) mesh finished, and the mesh would not be cancelled.
    token = qjulia.CancelToken()
    outcome = {}

    def work():
        try:
            qjulia.mesh(cancel=token, **LONG)
            outcome["result"] = "finished"
        except qjulia.Cancelled:
            outcome["result"] = "cancelled"

    thread = threading.Thread(target=work)
    thread.start()
    time.sleep(0.3)
    assert thread.is_alive()
    busy = sum(i * i for i in range(300000))  # Python code, which needs the GIL
    token.request()
    thread.join(timeout=60)
    assert busy > 0 and token.requested
    assert outcome.get("result") == "cancelled"
    token.reset()
    assert not token.requested


def test_a_requested_token_cancels_before_any_work():
    token = qjulia.CancelToken()
    token.request()
    t0 = time.monotonic()
    with pytest.raises(qjulia.Cancelled):
        qjulia.mesh(cancel=token, **LONG)
    assert time.monotonic() - t0 < 1


CHILD = textwrap.dedent("""
    import sys, qjulia
    started = []
    def progress(stage, fraction):
        if not started:
            started.append(stage)
            print("started", flush=True)
    try:
        qjulia.mesh(preset="newton-cubic", resolution=512, progress=progress)
        print("finished", flush=True)
        sys.exit(1)
    except KeyboardInterrupt:
        print("KeyboardInterrupt", flush=True)
        sys.exit(3)
""")


def test_ctrl_c_raises_keyboard_interrupt_within_a_second():
    child = subprocess.Popen([sys.executable, "-c", CHILD], stdout=subprocess.PIPE, text=True,
                             env=dict(os.environ))
    try:
        assert child.stdout.readline().strip() == "started"
        time.sleep(0.5)  # well inside the sampling
        sent = time.monotonic()
        child.send_signal(signal.SIGINT)
        line = child.stdout.readline().strip()
        elapsed = time.monotonic() - sent
        assert line == "KeyboardInterrupt"
        assert elapsed < 1.0, f"KeyboardInterrupt {elapsed:.2f} s after SIGINT"
        assert child.wait(timeout=30) == 3
    finally:
        child.kill()
        child.wait()


@pytest.mark.parametrize("kind,python_type", [
    ("InvalidInput", ValueError),
    ("TooLarge", MemoryError),
    ("Cancelled", qjulia.Cancelled),
    ("runtime_error", RuntimeError),
])
def test_library_exceptions_become_the_python_exceptions_of_the_issue(kind, python_type):
    with pytest.raises(python_type, match="cancelled" if kind == "Cancelled" else "the message"):
        qjulia._core._throw_for_test(kind, "the message")


def test_a_bad_memory_size_is_a_value_error():
    with pytest.raises(ValueError, match="max_memory"):
        qjulia.mesh(resolution=8, max_memory="lots")
    for size in (-1, 0, 1000):
        with pytest.raises(ValueError, match="max_memory: expected at least 1M"):
            qjulia.mesh(resolution=8, max_memory=size)
    with pytest.raises(TypeError):
        qjulia.mesh(resolution=8, max_memory=True)


def test_the_memory_estimate_refuses_with_memory_error_before_the_work():
    calls = []
    t0 = time.monotonic()
    with pytest.raises(MemoryError, match="resolution 1024 needs about") as e:
        qjulia.mesh(preset="newton-cubic", resolution=1024, max_memory="64M",
                    progress=lambda stage, fraction: calls.append(stage))
    assert time.monotonic() - t0 < 5
    assert set(calls) <= {"estimate"}, calls  # refused before sampling
    assert "64.0 MiB" in str(e.value)
    assert qjulia.mesh(preset="classic-julia", resolution=16, max_memory=1 << 30).stats["faces"]


def test_bad_callbacks_and_tokens_are_type_errors():
    with pytest.raises(TypeError, match="progress"):
        qjulia.mesh(resolution=8, progress=3)
    with pytest.raises(TypeError):
        qjulia.mesh(resolution=8, cancel="stop")
