"""``wavekeep campaign``: a grid of missions on Dask distributed, resumable, with statistics across seeds.

By default the missions run on a :class:`distributed.LocalCluster` started for
the campaign: one worker process per core, one thread each, every endpoint
(scheduler, workers, dashboard) on 127.0.0.1. ``scheduler="tcp://HOST:8786"``
runs the same on an existing cluster. Workers import the installed package;
only a mission's :class:`~sitl.harness.campaign_spec.CampaignTask` (its RunSpec)
goes out and only its flat results row comes back.

Rows go to the journal (``DIR/missions.jsonl``) as missions finish; a rerun into
the same folder skips missions already there (:mod:`.campaign_store`). A
mission that raises is a ``failed`` row, and the campaign goes on. Ctrl-C
closes the cluster and raises :class:`KeyboardInterrupt` (the CLI exits 130);
the journal keeps every mission finished before it.
"""
from __future__ import annotations

import contextlib
import json
import logging
import os
import signal
import sys
import threading
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

from .blas import ONE_BLAS_THREAD
from .campaign_spec import CampaignSpec, CampaignTask
from .campaign_store import Journal, write_tables
from .campaign_task import TaskOutcome, run_task, spec_columns
from .progress import ProgressBar
from .stats import format_summary_table, summarise_campaign

__all__ = ["CampaignInterrupted", "CampaignProgress", "CampaignReport", "dask_client", "execute_tasks",
           "failure_text", "run_campaign"]

WORKER_ENV = ONE_BLAS_THREAD
"""One BLAS thread per worker: the workers already fill the cores."""

log = logging.getLogger("wavekeep.campaign")


class CampaignInterrupted(KeyboardInterrupt):
    """Ctrl-C during a campaign: how many of its missions are in the journal (a rerun resumes from there)."""

    def __init__(self, done: int, total: int):
        super().__init__(f"{done} of {total} done; rerun the same command to resume")
        self.done, self.total = done, total


@dataclass
class CampaignReport:
    """What a campaign run did: its rows (one per mission of the grid that has one), the summary, counts."""

    rows: list[dict[str, Any]]
    summary: dict[str, Any]
    ran: int
    skipped: int
    failed: int
    wall_s: float
    out: Path
    figures: list[Path] = field(default_factory=list)


class CampaignProgress:
    """done/total, elapsed, ETA and failures on the shared :class:`~sitl.harness.progress.ProgressBar`:
    a tqdm bar on a terminal, else a log line every ``interval`` s."""

    def __init__(self, total: int, done: int = 0, stream: TextIO | None = None, interval: float = 10.0,
                 enabled: bool = True):
        self.total, self.done, self.failed, self.ran = total, done, 0, 0
        self.stream = stream or sys.stderr
        self.t0 = time.monotonic()
        self._bar = ProgressBar(total, "campaign", self.stream, enabled=enabled, unit="mission", interval=interval,
                                initial=done, line=self.line)

    def line(self) -> str:
        el = time.monotonic() - self.t0
        eta = el / self.ran * (self.total - self.done) if self.ran else float("nan")
        eta_s = f"{eta:.0f} s" if eta == eta else "?"
        return (f"campaign: {self.done}/{self.total} missions, elapsed {el:.0f} s, ETA {eta_s}, "
                f"{self.failed} failed")

    def update(self, row: dict[str, Any]) -> None:
        self.done += 1
        self.ran += 1
        self.failed += row.get("status") != "ok"
        self._bar.set_postfix(failed=self.failed)
        self._bar.update(self.done)

    def close(self) -> None:
        self._bar.close(completed=self.done >= self.total)


@contextlib.contextmanager
def dask_client(scheduler: str | None = None, workers: int | None = None,
                say: Callable[[str], None] = print) -> Iterator[Any]:
    """A connected :class:`distributed.Client`: to ``scheduler`` if given, else to a loopback LocalCluster of
    ``workers`` processes (default: one per core), one thread each. Closed (cluster too) on exit."""
    from distributed import Client, LocalCluster

    if scheduler:
        client = Client(scheduler, timeout="20s")
        try:
            say(f"campaign: on the cluster at {scheduler}, {len(client.nthreads())} workers")
            yield client
        finally:
            client.close(timeout=5)
        return
    n = workers or os.cpu_count() or 1
    cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                           dashboard_address="127.0.0.1:0", silence_logs=logging.CRITICAL, env=dict(WORKER_ENV))
    client = Client(cluster)
    try:
        dash = client.dashboard_link if _has_bokeh() else "off (pip install bokeh to get it)"
        say(f"campaign: local cluster {cluster.scheduler_address}, {n} worker(s), dashboard {dash}")
        yield client
    except KeyboardInterrupt:
        _kill_workers(cluster)     # a graceful close waits for the missions in flight; Ctrl-C should not
        raise
    finally:
        client.close(timeout=5)
        with contextlib.suppress(Exception):
            cluster.close(timeout=10)


def _kill_workers(cluster: Any) -> None:
    """SIGKILL the local cluster's worker processes (our own children, by pid)."""
    for nanny in list(getattr(cluster, "workers", {}).values()):
        pid = getattr(getattr(getattr(nanny, "process", None), "process", None), "pid", None)
        if pid:
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)


def _has_bokeh() -> bool:
    try:
        import bokeh  # noqa: F401
    except ImportError:
        return False
    return True


class _DeferSigint:
    """Hold a Ctrl-C that arrives while a row is being written; deliver it right after."""

    def __init__(self) -> None:
        self.pending = False
        self.active = threading.current_thread() is threading.main_thread()
        self._old: Any = None

    @contextlib.contextmanager
    def __call__(self) -> Iterator[None]:
        if not self.active:
            yield
            return
        self._old = signal.signal(signal.SIGINT, self._hold)
        try:
            yield
        finally:
            signal.signal(signal.SIGINT, self._old)
            if self.pending:
                self.pending = False
                raise KeyboardInterrupt

    def _hold(self, *_: Any) -> None:
        self.pending = True


def _lost_row(task: CampaignTask, exc: BaseException) -> dict[str, Any]:
    """A row for a mission the cluster lost (worker died, cancelled): retried by the next run."""
    return {**spec_columns(task), "status": "lost", "error": f"{type(exc).__name__}: {exc}", "worker": None,
            "task_wall_s": None, "finished_at": time.time()}


def _window(client: Any) -> int:
    """Missions to keep queued: four per worker thread, at least eight (the cluster may grow or shrink)."""
    return max(8, 4 * sum(client.nthreads().values()))


def execute_tasks(client: Any, tasks: Sequence[CampaignTask],
                  on_outcome: Callable[[CampaignTask, TaskOutcome], None], window: int | None = None) -> None:
    """Run ``tasks`` on ``client``'s cluster, calling ``on_outcome`` (in this thread) as each finishes.

    At most ``window`` missions are queued on the cluster at a time (default: four per worker thread, at
    least eight, re-read every few seconds as workers join or leave), so an interrupt loses only those.
    On :class:`KeyboardInterrupt` the queued ones are cancelled.
    """
    from distributed import as_completed

    token = uuid.uuid4().hex[:8]
    queue = list(reversed(tasks))
    by_key: dict[str, CampaignTask] = {}
    ac = as_completed(loop=client.loop)
    target, checked = window or _window(client), time.monotonic()
    try:
        while queue or not ac.is_empty():
            if window is None and time.monotonic() - checked > 5.0:
                target, checked = _window(client), time.monotonic()
            while queue and ac.count() < target:
                t = queue.pop()
                key = f"wavekeep-{token}-{t.mission_id}"
                by_key[key] = t
                ac.add(client.submit(run_task, t, key=key, pure=False, retries=0))
            if not ac.has_ready():
                time.sleep(0.05)      # poll: a blocking wait would hold off Ctrl-C until a mission ends
                continue
            for fut in ac.next_batch(block=False):
                task = by_key.pop(fut.key)
                try:
                    outcome = fut.result()
                except Exception as exc:   # the cluster lost it; a mission's own failure never leaves run_task
                    outcome = TaskOutcome(_lost_row(task, exc))
                fut.release()
                on_outcome(task, outcome)
    except KeyboardInterrupt:
        pending = list(ac.futures)
        ac.clear()
        client.cancel(pending, force=True)
        raise


def _write_outputs(spec: CampaignSpec, rows: list[dict[str, Any]], out: Path, plots: bool) -> tuple[dict, list]:
    """missions.parquet/.csv, summary.json and (optionally) the figures."""
    write_tables(rows, out)
    summary = summarise_campaign(rows, spec.cases, [v.name for v in spec.variants], spec.baseline,
                                 spec.bootstrap_resamples, spec.bootstrap_seed,
                                 {v.name: v.baseline for v in spec.variants if v.baseline})
    summary.update(campaign=spec.name, missions=len(spec.tasks()),
                   done=sum(r.get("status") == "ok" for r in rows),
                   failed=sum(r.get("status") != "ok" for r in rows))
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    figures: list[Path] = []
    if plots and any(r.get("status") == "ok" for r in rows):
        from .campaign_plots import plot_campaign
        figures = plot_campaign(rows, summary, spec, out)
    return summary, figures


def run_campaign(spec: CampaignSpec, out: str | Path, scheduler: str | None = None, workers: int | None = None,
                 retry_failed: bool = False, plots: bool = True, stream: TextIO | None = None,
                 log_interval: float = 10.0) -> CampaignReport:
    """Run every mission of ``spec`` not already in ``out``'s journal, then write the tables, summary and figures."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    stream = stream or sys.stderr
    (out / "campaign.json").write_text(json.dumps(spec.to_dict(), indent=2))
    tasks = spec.tasks()
    t0 = time.perf_counter()
    with Journal(out) as journal:
        done = journal.done(tasks, retry_failed)
        todo = [t for t in tasks if t.mission_id not in done]
        print(f"campaign {spec.name!r}: {len(tasks)} missions, {len(done)} already done, {len(todo)} to run",
              file=stream, flush=True)
        progress = CampaignProgress(len(tasks), len(done), stream, log_interval)
        defer = _DeferSigint()

        def record(task: CampaignTask, outcome: TaskOutcome) -> None:
            with defer():
                journal.append(outcome.row)
            progress.update(outcome.row)

        try:
            if todo:
                with dask_client(scheduler, workers, say=lambda m: print(m, file=stream, flush=True)) as client:
                    execute_tasks(client, todo, record)
        except KeyboardInterrupt:
            raise CampaignInterrupted(progress.done, len(tasks)) from None
        finally:
            progress.close()
        latest = journal.latest()
    wall = time.perf_counter() - t0
    rows = [latest[t.mission_id] for t in tasks
            if t.mission_id in latest and latest[t.mission_id].get("spec_hash") == t.spec_hash]
    summary, figures = _write_outputs(spec, rows, out, plots)
    summary["wall_time_s"] = wall
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    return CampaignReport(rows, summary, len(todo), len(done), sum(r.get("status") != "ok" for r in rows), wall,
                          out, figures)


def failure_text(report: CampaignReport) -> str | None:
    """None if every mission flew; else the first distinct errors and, last, how many failed and where
    each one's error is (the ``error`` column of missions.csv)."""
    bad = [r for r in report.rows if r.get("status") != "ok"]
    if not bad:
        return None
    errors = list(dict.fromkeys(str(r.get("error") or r.get("status")) for r in bad))
    lines = [f"  {e[:300]}" for e in errors[:3]] + ([f"  ... and {len(errors) - 3} more"] if len(errors) > 3 else [])
    return "\n".join(["errors:", *lines,
                      f"{len(bad)} of {len(report.rows)} missions failed: each one's error is in the error column of "
                      f"{report.out / 'missions.csv'} (rerun with --retry-failed to fly them again)"])


def report_text(report: CampaignReport) -> str:
    """The printed summary: the statistics table and where things went."""
    s = report.summary
    rate = 3600.0 * report.ran / report.wall_s if report.wall_s > 0 and report.ran else float("nan")
    return "\n".join([format_summary_table(s), "",
                      f"{s['done']}/{s['missions']} missions done, {s['failed']} failed; ran {report.ran} "
                      f"(skipped {report.skipped} already done) in {report.wall_s:.1f} s"
                      + (f" ({rate:.0f} missions/hour)" if rate == rate else ""),
                      f"wrote {report.out}/missions.parquet, missions.csv, summary.json"
                      + (f" and {len(report.figures)} figures" if report.figures else "")])
