"""Running a campaign's jobs: one run in a worker, and the Dask engine that spreads them.

Dask (``distributed``) rather than Ray: on this project's 2-core machines a
local cluster of Dask starts in ~2 s in ~160 MB from a 2.5 MB pure-Python
install, against Ray's ~6 s, ~700 MB of daemons and an 80 MB binary wheel,
and it needs no set-up either way (README, "Campaigns").

Each worker is a process of its own with one thread: python-can's virtual bus
joins every bus of a process that names the same channel, so two rigs must
never share a process at the same time.
"""
from __future__ import annotations

import logging
import math
import os
import re
import shutil
import signal
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable, Iterator

from wheelleg.hil.campaign.sampling import Job
from wheelleg.hil.record.run_metadata import run_command
from wheelleg.hil.robots import split_name

_NUMBER = re.compile(r"[-+]?(?:nan|inf|(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)", re.IGNORECASE)


@dataclass(frozen=True)
class RunSettings:
    """What every run of a campaign shares: where it writes, how long, what it keeps."""

    out_dir: Path
    duration_s: float | None = None  # None: each scenario's own duration
    keep_passing: bool = False  # keep passing runs' traces and logs too (disk)
    epoch_ns: int = 0  # the candump logs' start time (``wheelleg run --epoch``)
    program: str = "python"  # ``--program``: an in-process kind (hil/program), parsed on the worker


def rig_config(seed: int, overrides: dict, epoch_ns: int = 0, program: str = "python"):
    """The one place a sample's plant overrides become a run's RigConfig (ValueError on a bad key or value,
    or a program that is not an in-process one)."""
    from wheelleg.emulators.plant import PlantConfig
    from wheelleg.hil import program as programs
    from wheelleg.hil.run.rig import RigConfig

    chosen = programs.parse(program)
    if not chosen.in_process:
        raise ValueError(f"program {program!r}: a campaign runs in-process programs (python, firmware, PATH.so)")
    return RigConfig(seed=seed, plant=PlantConfig.from_overrides(overrides), epoch_ns=epoch_ns, program=chosen)


def check_ranges(ranges: dict[str, tuple[float, float]]) -> None:
    """ValueError (one line) unless the plant takes every key at both ends of its range."""
    for key, span in ranges.items():
        for value in span:
            try:
                rig_config(0, {key: value})
            except ValueError as exc:
                raise ValueError(f"--vary {key}: {exc}") from None


def rerun_command(job: Job, settings: RunSettings) -> str:
    """The one command that runs ``job`` alone (the same candump log, byte for byte), shell-quoted."""
    return run_command(job.scenario, job.seed, settings.duration_s, job.overrides,
                       out=run_dir(job, settings) / "rerun", epoch_ns=settings.epoch_ns, program=settings.program)


def run_dir(job: Job, settings: RunSettings) -> Path:
    return settings.out_dir / "runs" / job.scenario / f"sample-{job.sample:04d}"


def first_number(detail: str) -> float | None:
    """The figure a check reports: the first number in its detail ("max drift 3.1 cm (limit 5)" -> 3.1).

    None when there is none or it is not finite ("max |pitch| nan deg": the run had no such window).
    """
    match = _NUMBER.search(detail)
    value = float(match.group()) if match else math.nan
    return value if math.isfinite(value) else None


def run_job(job: Job, settings: RunSettings) -> dict:
    """Run ``job`` in the rig and judge it; its results row (results.jsonl). Never raises for a bad run."""
    from wheelleg.hil import scenarios
    from wheelleg.hil.program.checks import program_checks
    from wheelleg.hil.record.rundata import load_run
    from wheelleg.hil.run.rig import Rig

    where = run_dir(job, settings)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    row = failed_row(job, None)
    try:
        scenario = scenarios.get(job.scenario)
        if settings.duration_s is not None:
            scenario = replace(scenario, duration_s=settings.duration_s)
        outcome = Rig(scenario, rig_config(job.seed, job.overrides, settings.epoch_ns, settings.program), where).run()
        row["sim_s"] = outcome.sim_s
        run = load_run(outcome.trace_path)
        results = [check(run) for check in (*scenario.checks, *program_checks(run.program))]
        row["checks"] = [{"name": r.name, "passed": r.passed, "figure": first_number(r.detail),
                          "detail": r.detail, **({} if r.applies else {"applies": False})} for r in results]
        row["passed"] = all(r.passed for r in results)
    except Exception as exc:  # noqa: BLE001 - a run that cannot run has failed, with the reason kept
        row["error"] = f"{type(exc).__name__}: {exc}".splitlines()[0]
    row["wall_s"] = round(time.perf_counter() - wall0, 3)
    row["cpu_s"] = round(time.process_time() - cpu0, 3)  # this worker process's CPU: the run, its checks
    row = finish_files(row, job, settings)
    if not row["passed"] and row["trace"] and not row.get("error"):
        from wheelleg.hil.watch.failure_video import add_failure_video  # noqa: PLC0415

        add_failure_video(row, settings.out_dir)  # after cpu_s: the video is not the run's cost
    return row


def failed_row(job: Job, error: str | None) -> dict:
    """A row for ``job`` with no checks yet: failed, with ``error`` if the run could not run."""
    return {"scenario": job.scenario, "sample": job.sample, "seed": job.seed,
            "overrides": job.overrides, "passed": False, "checks": [], "error": error}


def finish_files(row: dict, job: Job, settings: RunSettings) -> dict:
    """Keep a failing run's trace and log (with its rerun command), drop a passing one's."""
    where = run_dir(job, settings)
    if row["passed"] and not settings.keep_passing:
        shutil.rmtree(where, ignore_errors=True)
        row["trace"] = None
    else:
        name = split_name(job.scenario)[1]  # the rig names its files by the bare scenario name
        row["trace"] = str((where / f"{name}.mcap").relative_to(settings.out_dir))
    row["rerun"] = rerun_command(job, settings)
    return row


Runner = Callable[[Job, RunSettings], dict]


LOOPBACK = "127.0.0.1"
WORKER_ENV = {name: "1" for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")}


def dashboard_address(text: str | None) -> str | None:
    """``--dashboard``'s value as Dask's dashboard address: None (no dashboard), ``""`` (loopback,
    a free port), ``PORT`` or ``HOST:PORT`` (the host the user names, else loopback)."""
    if text is None:
        return None
    host, _, port = text.rpartition(":") if ":" in text else ("", "", text)
    port = port or "0"
    if not port.isdigit() or int(port) > 65535:
        raise ValueError(f"--dashboard {text!r}: expected [HOST:]PORT, e.g. 8787 or 0.0.0.0:8787")
    return f"{host or LOOPBACK}:{port}"


def cluster_options(workers: int | None, processes: bool, dashboard: str | None) -> dict:
    """``LocalCluster``'s keyword arguments: ``workers`` single-thread workers (default one per core),
    every listener on loopback, and the dashboard at ``dashboard`` (``dashboard_address``'s value;
    None: no dashboard).

    One worker per core, one thread each, their BLAS pools at one thread (WORKER_ENV): a run is
    one thread of Python and MuJoCo, more would oversubscribe. Without a dashboard the scheduler
    still serves its health and metrics routes over HTTP; Dask puts that server on port 8787 and,
    with a second campaign running, warns that the port is taken: it goes to a free port instead.
    """
    options = dict(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1, processes=processes,
                   dashboard_address=dashboard, memory_limit=0, silence_logs=logging.ERROR)
    if dashboard is None:
        options["scheduler_kwargs"] = {"dashboard": False, "dashboard_address": f"{LOOPBACK}:0"}
    if processes:
        options.update(host=LOOPBACK, env=WORKER_ENV)
    return options


class Engine:
    """A Dask client: a local cluster of ``workers`` single-thread processes, or ``address``'s cluster.

    ``processes=False`` keeps the workers as threads of this process (only for
    runners that share nothing, such as tests' fakes).
    """

    def __init__(self, address: str | None = None, workers: int | None = None, processes: bool = True,
                 dashboard: str | None = None):
        from dask.distributed import Client, LocalCluster

        self.cluster = None
        if address is None:
            # Ctrl-C is the driver's to handle (it journals and closes the cluster): the worker
            # processes start with SIGINT ignored, which Python keeps across their start.
            previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
            try:
                # Every listener on loopback: the scheduler, the workers and their nannies, and
                # the dashboard only when asked for (Dask's default serves it on all interfaces).
                self.cluster = LocalCluster(**cluster_options(workers, processes, dashboard))
            finally:
                signal.signal(signal.SIGINT, previous)
            self.client = Client(self.cluster)
        else:
            try:
                self.client = Client(address, timeout="10s")
            except OSError as exc:
                raise OSError(f"cannot reach the Dask scheduler at {address}: {exc}") from None
            threaded = [w for w in self.client.scheduler_info()["workers"].values() if w["nthreads"] != 1]
            if threaded:
                self.client.close()
                raise OSError(f"{len(threaded)} worker(s) at {address} run several threads; two rigs must "
                              "not share a process: start them with `dask worker ADDRESS --nthreads 1`")

    def map(self, runner: Runner, jobs: list[Job], settings: RunSettings) -> Iterator[dict]:
        """Each job's row, in the order they finish."""
        from dask.distributed import as_completed

        futures = {self.client.submit(runner, job, settings, key=f"{job.scenario}-{job.sample}"): job
                   for job in jobs}
        try:
            for future in as_completed(futures):
                try:
                    yield future.result()
                except Exception as exc:  # noqa: BLE001 - e.g. the worker died (KilledWorker): a failed run
                    job = futures[future]
                    row = failed_row(job, f"{type(exc).__name__}: {exc}".splitlines()[0])
                    yield {**row, "wall_s": None, "trace": None, "rerun": rerun_command(job, settings)}
        finally:
            for future in futures:
                future.cancel()

    def close(self) -> None:
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()

    def __enter__(self) -> "Engine":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

