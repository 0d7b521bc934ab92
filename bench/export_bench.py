#!/usr/bin/env python3
"""Fleet dataset figures (issue: fleet analytics). Prints:

  1. `gimbalscope export` of K socat logs of saturated 115200-baud traffic, with
     1 worker and with 2: events/s, MB/s of input, dataset bytes per event, and
     the peak resident memory of the command and of its biggest worker
  1c. `gimbalscope export` of the same captures recorded as MCAP (with their stored
     columns) against `--redecode`: the ratio
  1b. with --spark: the same export on Spark local[1] and local[2] (the spark extra
     and Java 17): events/s, and the time Spark takes to start alone, which every
     --spark command pays once
  2. the time of each query of the README ("Queries") run
     by `gimbalscope query` on a dataset of about 10M events: one real export
     of N events, copied to further captures on further days with pyarrow
     (the same rows under another capture name, device group and date), so the
     big dataset costs seconds to make rather than the export's minutes

    python3 bench/export_bench.py [--captures 4] [--events-per-capture 250000] [--query-events 10000000]
                                  [--spark] [--skip-queries]
    python3 bench/export_bench.py --recording R.mcap [R2.mcap ...]    (1c only, of these recordings)
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.join(ROOT, "bench"))

from mcap_bench import EVENTS_PER_COMMAND, saturated

# the command's own peak (VmHWM) and its biggest child's (the pool's workers, waited for at the end)
_MEASURED = ("import resource, sys; from analyzer.cli.main import main; rc = main(sys.argv[1:]); "
             "hwm = [l for l in open('/proc/self/status') if l.startswith('VmHWM')][0].split()[1]; "
             "kids = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss; "
             "print(hwm, kids, file=sys.stderr); sys.exit(rc)")


def measured(args: list[str]) -> tuple[float, float, float]:
    """Seconds, the command's peak RSS and its biggest child's (MB)."""
    t = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", _MEASURED, *args], stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, text=True, cwd=ROOT, check=False)
    seconds = time.perf_counter() - t
    if proc.returncode != 0:
        raise SystemExit(proc.stderr)
    own, kids = proc.stderr.strip().splitlines()[-1].split()
    return seconds, int(own) / 1024, int(kids) / 1024


def make_logs(folder: str, count: int, events: int) -> list[str]:
    paths = []
    for i in range(count):
        path = os.path.join(folder, f"site-{i}.log")
        if not os.path.exists(path):
            tr = saturated(int(events / EVENTS_PER_COMMAND), seed=100 + i)
            with open(path + ".part", "w") as f:
                f.write(tr.socat_log())
            os.replace(path + ".part", path)
        paths.append(path)
    return paths


def folder_bytes(root: str) -> int:
    return sum(os.path.getsize(os.path.join(d, f)) for d, _, files in os.walk(root) for f in files)


def dataset_events(root: str) -> int:
    from analyzer.dataset.query import connect
    return connect(root).execute("SELECT count(*) FROM events").fetchone()[0]


def throughput(logs: list[str], work: str) -> None:
    size = sum(os.path.getsize(p) for p in logs)
    for jobs in (1, 2):
        out = os.path.join(work, f"ds-j{jobs}")
        shutil.rmtree(out, ignore_errors=True)
        seconds, own, kids = measured(["export", *logs, "-o", out, "-j", str(jobs), "--baud", "115200", "-q"])
        n = dataset_events(out)
        print(f"1. export -j {jobs} of {len(logs)} socat logs ({size / 1e6:.0f} MB, {n:,} events): {seconds:.1f} s, "
              f"{n / seconds:,.0f} events/s, {size / 1e6 / seconds:.1f} MB/s; dataset {folder_bytes(out) / n:.1f} "
              f"bytes/event; peak RSS {own:.0f} MB (command), {kids:.0f} MB (biggest worker)", flush=True)


def recordings(logs: list[str], work: str) -> None:
    """Export of the same captures recorded (MCAP, carrying their stored columns)
    against the same export decoding their raw bytes (--redecode)."""
    paths = []
    for log in logs:
        path = os.path.join(work, os.path.basename(log).removesuffix(".log") + ".mcap")
        if not os.path.exists(path):
            subprocess.run([sys.executable, "-m", "analyzer", "convert", log, "--baud", "115200", "-o", path, "-q",
                            "--force"], cwd=ROOT, check=True, stderr=subprocess.DEVNULL)
        paths.append(path)
    stored_against_redecode(paths, work)


def stored_against_redecode(paths: list[str], work: str) -> None:
    """``paths`` (recordings) exported from their stored columns, then with --redecode: the ratio."""
    times = {}
    for extra in ([], ["--redecode"]):
        out = os.path.join(work, "ds-mcap")
        shutil.rmtree(out, ignore_errors=True)
        times[bool(extra)] = measured(["export", *paths, "-o", out, "-j", "1", "-q", *extra])[0]
    n = dataset_events(out)
    print(f"1c. export -j 1 of {len(paths)} recording{'s' * (len(paths) != 1)} ({n:,} events): {times[False]:.1f} s reading "
          f"the recordings' stored columns, {times[True]:.1f} s with --redecode: {times[True] / times[False]:.2f}x "
          "(target >= 10x; docs/dataset.md, \"Exporting a recording\")", flush=True)


_SPARK_START = ("import time; t = time.perf_counter(); from analyzer.dataset.spark.session import start; "
                "s = start('local[1]', 'start'); print(time.perf_counter() - t); s.stop()")


def on_spark(logs: list[str], work: str) -> None:
    """The export of ``throughput`` on Spark local[N]: the same inputs, the same dataset."""
    size = sum(os.path.getsize(p) for p in logs)
    proc = subprocess.run([sys.executable, "-c", _SPARK_START], capture_output=True, text=True, cwd=ROOT,
                          check=False)
    if proc.returncode != 0:
        raise SystemExit(proc.stderr)
    print(f"1b. Spark start alone (a JVM, local[1]): {float(proc.stdout.split()[-1]):.1f} s", flush=True)
    for cores in (1, 2):
        out = os.path.join(work, f"ds-spark{cores}")
        shutil.rmtree(out, ignore_errors=True)
        seconds, _, _ = measured(["export", *logs, "-o", out, "--spark", f"local[{cores}]", "--baud", "115200",
                                  "-q"])
        n = dataset_events(out)
        print(f"1b. export --spark local[{cores}] of {len(logs)} socat logs ({size / 1e6:.0f} MB, {n:,} events): "
              f"{seconds:.1f} s, {n / seconds:,.0f} events/s, {size / 1e6 / seconds:.1f} MB/s "
              f"(Spark's start included)", flush=True)


def replicate(src: str, dst: str, copies: int) -> int:
    """``copies`` more captures made of ``src``'s rows, each a day later, its devices
    in another group (so that per-device queries see more devices)."""
    import pyarrow as pa
    import pyarrow.compute as pc
    import pyarrow.parquet as pq

    shutil.rmtree(dst, ignore_errors=True)
    shutil.copytree(src, dst)
    for table in ("events", "transactions", "findings"):
        files = [os.path.join(d, f) for d, _, fs in os.walk(os.path.join(src, table)) for f in fs
                 if f.endswith(".parquet")]
        for path in files:
            day = dt.date.fromisoformat(re.search(r"date=(\d{4}-\d\d-\d\d)", path).group(1))
            data = pq.read_table(path)
            for k in range(1, copies + 1):
                shifted = data
                for col in ("ts", "start", "end", "first_seen_ts"):
                    if col in shifted.column_names:
                        i = shifted.column_names.index(col)
                        moved = pc.add(shifted.column(col), pa.scalar(dt.timedelta(days=k), pa.duration("us")))
                        shifted = shifted.set_column(i, col, moved.cast(shifted.schema.field(col).type))
                i = shifted.column_names.index("capture")
                renamed = pc.binary_join_element_wise(pa.scalar(f"copy-{k}"), shifted.column("capture"), ":")
                shifted = shifted.set_column(i, "capture", renamed)
                if "device" in shifted.column_names:
                    i = shifted.column_names.index("device")
                    dev = pc.replace_substring_regex(shifted.column("device"), r"^\d+\.", f"{k + 1}.")
                    shifted = shifted.set_column(i, "device", dev)
                folder = os.path.join(dst, table, f"date={(day + dt.timedelta(days=k)).isoformat()}")
                os.makedirs(folder, exist_ok=True)
                name = f"copy-{k}-{os.path.basename(path)}"   # each source capture's copy a file of its own
                pq.write_table(shifted, os.path.join(folder, name), compression="zstd")
    return dataset_events(dst)


def readme_queries() -> list[tuple[str, str]]:
    """(title, SQL) of each query in the README's "### Queries" section."""
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as f:
        text = f.read()
    if "### Queries\n" not in text:
        return []
    part = re.split(r"\n##?#? ", text.split("### Queries\n", 1)[1], maxsplit=1)[0]
    return [(m.group(1).strip(), m.group(2).strip())
            for m in re.finditer(r"####\s*(.+?)\n.*?```sql\n(.*?)```", part, re.DOTALL)]


def queries(root: str, events: int) -> None:
    found = readme_queries()
    if not found:
        print("2. no queries found in the README (### Queries, #### title, ```sql blocks)")
        return
    for title, sql in found:
        seconds, own, _ = measured(["query", root, sql, "--format", "csv"])
        print(f"2. query on {events:,} events, '{title}': {seconds:.2f} s (peak RSS {own:.0f} MB)", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--captures", type=int, default=4)
    ap.add_argument("--events-per-capture", type=int, default=250_000)
    ap.add_argument("--query-events", type=int, default=10_000_000)
    ap.add_argument("--skip-export", action="store_true", help="only the queries, on the last run's export")
    ap.add_argument("--spark", action="store_true", help="also export on Spark local[1] and local[2]")
    ap.add_argument("--skip-queries", action="store_true", help="only the exports")
    ap.add_argument("--work", default=os.path.join(tempfile.gettempdir(), "gimbalscope-export-bench"))
    ap.add_argument("--recording", nargs="+", metavar="FILE.mcap",
                    help="only 1c, of these recordings (say, tui_bench.py's of 1M or 10M events)")
    args = ap.parse_args()
    os.makedirs(args.work, exist_ok=True)
    if args.recording:
        missing = [p for p in args.recording if not os.path.isfile(p)]
        if missing:
            raise SystemExit(f"export_bench.py: {missing[0]}: no such recording")
        stored_against_redecode([os.path.abspath(p) for p in args.recording], args.work)
        return
    print(f"making {args.captures} socat logs of {args.events_per_capture:,} events in {args.work} (once) ...",
          flush=True)
    logs = make_logs(args.work, args.captures, args.events_per_capture)
    if not args.skip_export:
        throughput(logs, args.work)
        recordings(logs, args.work)
        if args.spark:
            on_spark(logs, args.work)
    if args.skip_queries:
        return
    base = os.path.join(args.work, "ds-j2")
    if args.skip_export and not os.path.isdir(base):
        raise SystemExit(f"{base}: no export yet (run once without --skip-export)")
    n = dataset_events(base)
    copies = max(0, round(args.query_events / n) - 1)
    big = os.path.join(args.work, "ds-big")
    total = replicate(base, big, copies)
    queries(big, total)


if __name__ == "__main__":
    main()
