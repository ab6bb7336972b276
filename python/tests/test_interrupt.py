"""Progress, stopping and Ctrl-C during tetopt.improve.

Ctrl-C: a child interpreter improves a big mesh (again and again, so that a
fast machine is still inside improve); once its progress callback says the
rounds have begun, this test sends SIGINT at a few delays and
measures the time until the child reports the KeyboardInterrupt.  The
promise is 0.2 s; the assertion allows 0.2 s + MARGIN, because this suite
runs on small machines shared with other jobs (2 cores, 4 builds: a process
can wait its turn for the CPU for a good part of a second).  It is a bound
on responsiveness, not a speed test: without the polling inside the passes
the latency is a whole pass or round (seconds here: with the abort flag not
handed to the library this test measured 1.35-1.99 s and failed; with it,
27-62 ms).  The mesh is big so that a run outlasts the bound by far.  The
child then checks
that no thread is left computing (its CPU time does not grow while it
sleeps) and that only the main Python thread remains.
"""
import json
import math
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import tetopt

from conftest import run_cli

PROMISE_S = 0.2
MARGIN_S = 0.3

CHILD = r"""
import json, os, sys, threading, time
import tetopt
mesh = tetopt.read(sys.argv[1])
said = inside = False
def progress(phase, rnd, fraction, worst):
    global said
    if rnd >= 1 and phase == "all-boundary" and not said:
        said = True
        print("running", flush=True)
try:
    for _ in range(50):  # runs again and again until the signal (a fast machine ends one in a second)
        inside = True
        tetopt.improve_mesh(mesh, threads=2, progress=progress)
        inside = False
    print(json.dumps({"finished": True}), flush=True)
except KeyboardInterrupt:
    print("interrupted", flush=True)
    cpu0 = time.process_time()
    time.sleep(0.3)
    cpu = time.process_time() - cpu0
    tasks = len(os.listdir("/proc/self/task"))
    print(json.dumps({"finished": False, "inside_improve": inside, "cpu_while_idle": cpu,
                      "python_threads": threading.active_count(), "os_threads": tasks}), flush=True)
"""


@pytest.fixture(scope="module")
def big(cli, tmp_path_factory):
    """A jittered box of 1,296,000 tets: a `best` run takes seconds here."""
    path = tmp_path_factory.mktemp("big") / "big.mesh"
    run_cli(cli, "generate", path, "--cells", 60, 60, 60, "--jitter", 0.4, "--seed", 3)
    return path


@pytest.mark.parametrize("delay", [0.05, 0.4, 0.9])
def test_ctrl_c_raises_keyboard_interrupt_promptly(big, delay):
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1")
    p = subprocess.Popen([sys.executable, "-c", CHILD, str(big)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, env=env)
    try:
        line = p.stdout.readline().strip()
        assert line == "running", f"child did not start its rounds: {line!r} {p.stderr.read()}"
        time.sleep(delay)
        if p.poll() is not None:
            pytest.fail(f"the child ended before the signal: {p.stdout.read()} {p.stderr.read()}")
        t0 = time.monotonic()
        p.send_signal(signal.SIGINT)
        line = p.stdout.readline().strip()
        latency = time.monotonic() - t0
        rest = json.loads(p.stdout.readline())
        p.wait(timeout=30)
    finally:
        if p.poll() is None:
            p.kill()
    print(f"KeyboardInterrupt latency {latency:.3f} s (signal {delay} s into the rounds)")
    assert line == "interrupted", (line, p.stderr.read())
    assert rest["finished"] is False
    assert rest["inside_improve"] is True  # the signal came during improve, not between two calls
    assert latency < PROMISE_S + MARGIN_S, f"KeyboardInterrupt came {latency:.3f} s after SIGINT"
    # Nothing left computing after the exception: no worker thread of the run.
    assert rest["cpu_while_idle"] < 0.05, rest
    assert rest["python_threads"] == 1, rest
    assert p.returncode == 0


def test_progress_reports_every_phase_and_false_stops(box):
    mesh = tetopt.read(box)
    seen = []
    out, report = tetopt.improve_mesh(mesh, progress=lambda *a: seen.append(a))
    assert report["stopped_early"] is False
    phases = [s[0] for s in seen]
    assert phases[0] == "start" and phases[-1] == "done"
    assert {"all-boundary", "flips", "pairs", "smooth", "smooth-maxmin"} <= set(phases)
    fractions = [s[2] for s in seen]
    assert fractions == sorted(fractions) and fractions[-1] == 1.0
    assert math.isclose(seen[-1][3], report["after"]["alpha_worst"], rel_tol=0, abs_tol=1e-12)
    full_rounds = report["operations"]["rounds"]

    # False stops at that phase: a valid, checked mesh and stopped_early.
    calls = []

    def stop_after_flips(phase, rnd, fraction, worst):
        calls.append(phase)
        return not (phase == "flips" and rnd == 1)

    out2, report2 = tetopt.improve_mesh(mesh, progress=stop_after_flips)
    assert report2["stopped_early"] is True
    assert report2["boundary_unchanged"]["checked"] and report2["boundary_unchanged"]["ok"]
    assert report2["operations"]["rounds"] == 1 < full_rounds
    assert report2["operations"]["smoothing_moves"] == 0
    assert calls[-1] == "flips"
    out2.validate()
    q = tetopt.quality(out2)
    assert q["alpha_worst"] >= report2["before"]["alpha_worst"]
    assert not np.array_equal(out2.points, out.points) or not np.array_equal(out2.tets, out.tets)


def test_progress_exception_stops_and_is_raised(box):
    mesh = tetopt.read(box)

    def boom(phase, *_):
        if phase == "flips":
            raise ZeroDivisionError("from the callback")

    with pytest.raises(ZeroDivisionError, match="from the callback"):
        tetopt.improve(mesh.points, mesh.tets, mesh.refs, progress=boom)
    with pytest.raises(ValueError, match="progress: expected a callable"):
        tetopt.improve(mesh.points, mesh.tets, progress=3)
