"""Shared benchmark plumbing: the machine's description, percentiles, writing results."""
from __future__ import annotations

import json
import os
import platform
import sys
import time
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

RESULTS = Path(__file__).resolve().parent / "results"


def machine() -> dict:
    """What the figures were measured on."""
    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        load = os.getloadavg()
    except OSError:
        load = None
    return {
        "cpu": cpu, "cores": os.cpu_count(), "platform": platform.platform(),
        "python": sys.version.split()[0], "numpy": np.__version__, "load_avg": load,
        "date": datetime.now(UTC).isoformat(timespec="seconds"),
    }


def percentiles_us(samples_s) -> dict:
    a = np.asarray(samples_s, dtype=float) * 1e6
    return {"p50_us": float(np.percentile(a, 50)), "p99_us": float(np.percentile(a, 99)),
            "max_us": float(a.max()), "mean_us": float(a.mean()), "n": int(a.size)}


def timed(fn, repeat: int) -> list[float]:
    out = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return out


def write(name: str, figures: dict) -> Path:
    RESULTS.mkdir(parents=True, exist_ok=True)
    path = RESULTS / f"{name}.json"
    path.write_text(json.dumps({"benchmark": name, "machine": machine(), "figures": figures}, indent=2))
    return path


def campaign_rows(folder: Path) -> list[dict]:
    """A campaign's finished missions from its journal (``missions.jsonl``), the last row per mission id:
    what a running or interrupted campaign has done so far, as well as a finished one."""
    rows: dict[str, dict] = {}
    for line in (Path(folder) / "missions.jsonl").read_text(encoding="utf-8").splitlines():
        if line.strip():
            r = json.loads(line)
            if r.get("status") == "ok":
                rows[r["mission_id"]] = r
    return list(rows.values())


def read_rows(path: str | Path) -> list[dict[str, str]]:
    """A campaign's ``missions.csv`` as dicts of strings."""
    import csv

    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def emit_checks(doc: dict, out: str | None) -> int:
    """Print an acceptance document (and write it to ``out``); 0 when every check in ``doc["checks"]`` passes."""
    text = json.dumps(doc, indent=1)
    if out:
        Path(out).write_text(text + "\n", encoding="utf-8")
    print(text)
    return 0 if all(c["pass"] for c in doc["checks"].values()) else 1

