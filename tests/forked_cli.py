"""Many runs of the ``gimbalscope`` command, each in a process of its own, at the
cost of the run alone: for corpora of hundreds of damaged inputs
(tests/hostile/test_instrument_corpus.py).

Starting the interpreter and importing the command takes about half a second a
run here, more than most runs of a small input take. So a server process
imports the command (and the readers, numpy) once, and forks a child for each
run: the child calls the console script's ``main`` with the run's arguments, its
standard output and error in files, and ends as the interpreter would end
``sys.exit(main())``: the status main returns, or a traceback on standard error
and status 1 for an exception that escapes. The server runs a few children at a
time and kills one that outlives its timeout (a hang), and reports each run's
status, time and peak memory.

    python -m tests.forked_cli JOBS.json RESULTS.json

JOBS.json: ``{"parallel": 2, "jobs": [{"id", "argv", "stdout", "stderr",
"timeout"}, …]}``; RESULTS.json: ``{id: {"code", "timed_out", "seconds", "cpu",
"max_rss_mb"}}`` (``code`` is -SIGNAL for a child killed by a signal).
"""

from __future__ import annotations

import gc
import importlib
import json
import os
import signal
import subprocess
import sys
import time
import traceback

from tests.conftest import ROOT

# what the commands load when they read a logic analyser's or a USB capture:
# imported once here, not in every child
PRELOAD = ("numpy", "analyzer.cli.main", "analyzer.sources.sigrok", "analyzer.sources.vcd",
           "analyzer.sources.saleae_csv", "analyzer.sources.saleae_binary", "analyzer.sources.saleae_table",
           "analyzer.sources.sampled", "analyzer.sources.usb", "analyzer.sources.pcapngfile",
           "analyzer.analysis.doctor")


def _child(job: dict) -> None:
    """In the forked child: one run of the command; never returns."""
    code = 1
    try:
        null = os.open(os.devnull, os.O_RDONLY)
        out = os.open(job["stdout"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        err = os.open(job["stderr"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        for fd, to in ((null, 0), (out, 1), (err, 2)):
            os.dup2(fd, to)
            os.close(fd)
        # the server's stdin object may hold buffered bytes
        sys.stdin = open(os.devnull)  # noqa: SIM115 - the child's stdin until it exits
        sys.argv = ["gimbalscope", *job["argv"]]
        from analyzer.cli.main import main
        try:
            code = main(job["argv"])
        except SystemExit as e:                 # as the interpreter turns SystemExit into a status
            if e.code is None:
                code = 0
            elif isinstance(e.code, int):
                code = e.code
            else:
                print(e.code, file=sys.stderr)
                code = 1
        except BaseException:  # noqa: BLE001 - as the interpreter reports an uncaught exception
            traceback.print_exc()
            code = 1
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except Exception:  # noqa: BLE001, S110 - nothing may keep the forked child from os._exit
                pass
        os._exit(code & 0xFF if isinstance(code, int) else 1)


def serve(jobs: list[dict], parallel: int) -> dict[str, dict]:
    os.chdir(ROOT)
    for name in PRELOAD:
        importlib.import_module(name)
    from analyzer.cli.main import build_parser

    build_parser()   # every command's module (main imports only the one it runs)
    gc.freeze()      # the imported objects: a child's collections then leave their pages shared
    waiting = list(reversed(jobs))
    running: dict[int, tuple[dict, float, bool]] = {}     # pid → (job, started, killed)
    results: dict[str, dict] = {}
    while waiting or running:
        while waiting and len(running) < parallel:
            job = waiting.pop()
            sys.stdout.flush()
            sys.stderr.flush()
            pid = os.fork()
            if pid == 0:
                _child(job)
            running[pid] = (job, time.monotonic(), False)
        pid, status, usage = os.wait4(-1, os.WNOHANG)
        if pid == 0:
            now = time.monotonic()
            for p, (job, started, killed) in list(running.items()):
                if not killed and now - started > job["timeout"]:
                    os.kill(p, signal.SIGKILL)
                    running[p] = (job, started, True)
            time.sleep(0.002)
            continue
        job, started, killed = running.pop(pid)
        code = os.waitstatus_to_exitcode(status)
        results[job["id"]] = {"code": code, "timed_out": killed, "seconds": round(time.monotonic() - started, 3),
                              "cpu": round(usage.ru_utime + usage.ru_stime, 3),
                              "max_rss_mb": round(usage.ru_maxrss / 1024, 1)}
    return results


def run_many(jobs: list[dict], workdir, parallel: int = 2) -> dict[str, dict]:
    """Run ``jobs`` through a server process (``workdir``: where the job and result
    files go); each job's result by its id."""
    jobs_path, results_path = os.path.join(workdir, "jobs.json"), os.path.join(workdir, "results.json")
    with open(jobs_path, "w") as f:
        json.dump({"parallel": parallel, "jobs": jobs}, f)
    budget = 60 + sum(j["timeout"] for j in jobs) / parallel
    done = subprocess.run([sys.executable, "-m", "tests.forked_cli", jobs_path, results_path], cwd=ROOT,
                          capture_output=True, text=True, timeout=budget, check=False)
    assert done.returncode == 0, done.stderr
    with open(results_path) as f:
        return json.load(f)


if __name__ == "__main__":
    with open(sys.argv[1]) as f:
        given = json.load(f)
    found = serve(given["jobs"], given.get("parallel", 2))
    with open(sys.argv[2], "w") as f:
        json.dump(found, f)
