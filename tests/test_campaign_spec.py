"""Campaign files, the journal and the statistics: fast tests, no cluster."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from bridge.configfile import ConfigError
from sitl.harness.campaign_spec import load_campaign_spec
from sitl.harness.campaign_store import Journal, read_journal, write_tables
from sitl.harness.campaign_task import flatten_results
from sitl.harness.stats import bootstrap_ci, summarise_campaign

ROOT = Path(__file__).resolve().parents[1]
BASE = {"name": "t", "cases": ["W1"], "seeds": [1, 2], "duration": 3, "baseline": "cpd",
        "variants": [{"name": "cpd", "controller": "cpd"}, {"name": "ff", "controller": "cpd_ff"}]}


def write(tmp_path, doc, name="c.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(doc))
    return path


def test_the_shipped_campaigns_expand_to_their_grids():
    paper = load_campaign_spec(ROOT / "configs/campaign/paper_30_seeds.yaml")
    assert len(paper.tasks()) == 270 and paper.seeds == tuple(range(1, 31)) and paper.baseline == "cpd"
    smoke = load_campaign_spec(ROOT / "configs/campaign/smoke.yaml")
    ids = [t.mission_id for t in smoke.tasks()]
    assert len(ids) == len(set(ids)) == 18
    assert smoke.tasks()[-1].spec.overrides == {"WK_FF_GAIN": 0.8}


@pytest.mark.parametrize("change, key", [
    (lambda d: d["variants"][0].update(snr_db=15), "variants[0].snr_db"),
    (lambda d: d.update(seeds={"from": 5, "to": 2}), "seeds.to"),
    (lambda d: d.update(seeds=[1, "two"]), "seeds[1]"),
    (lambda d: d.update(seeds={"from": 1}), "seeds.to"),
    (lambda d: d.update(baseline="nope"), "baseline"),
    (lambda d: d.update(colour="red"), "colour"),
    (lambda d: d["variants"][1].update(controller="pid"), "variants[1].controller"),
    (lambda d: d["variants"][1].update(overrides={"FF_GAIN": 1.0}), "variants[1].overrides.FF_GAIN"),
    (lambda d: d["variants"][1].update(overrides={"WK_FF_GAIN": "high"}), "variants[1].overrides.WK_FF_GAIN"),
    (lambda d: d["variants"][1].update(name="cpd"), "variants[1].name"),
    (lambda d: d.update(cases=["W9"]), "cases[0]"),
    (lambda d: d.update(duration=-1), "duration"),
    (lambda d: d.pop("seeds"), "seeds"),
])
def test_spec_errors_name_the_file_and_the_key(tmp_path, change, key):
    doc = json.loads(json.dumps(BASE))
    change(doc)
    path = write(tmp_path, doc)
    with pytest.raises(ConfigError) as err:
        load_campaign_spec(path)
    assert err.value.key == key
    assert str(path) in str(err.value) and f"key '{key}'" in str(err.value)


def test_seed_range_and_relative_sea_paths(tmp_path):
    (tmp_path / "seas").mkdir()
    calm = (ROOT / "configs/sea/W1.yaml").read_text().replace("name: W1", "name: calm")
    (tmp_path / "seas" / "calm.yaml").write_text(calm)
    path = write(tmp_path, dict(BASE, seeds={"from": 3, "to": 6}, cases=["W2", "seas/calm.yaml"]))
    spec = load_campaign_spec(path)
    assert spec.seeds == (3, 4, 5, 6)
    assert spec.cases[1] == str((tmp_path / "seas" / "calm.yaml").resolve())
    assert len(spec.tasks()) == 2 * 4 * 2


def test_journal_skips_a_torn_line_and_counts_only_matching_specs(tmp_path):
    spec = load_campaign_spec(write(tmp_path, BASE))
    tasks = spec.tasks()
    with Journal(tmp_path) as j:
        j.append({"mission_id": tasks[0].mission_id, "spec_hash": tasks[0].spec_hash, "status": "ok"})
        j.append({"mission_id": tasks[1].mission_id, "spec_hash": "other", "status": "ok"})
        j.append({"mission_id": tasks[2].mission_id, "spec_hash": tasks[2].spec_hash, "status": "failed"})
        j.append({"mission_id": tasks[3].mission_id, "spec_hash": tasks[3].spec_hash, "status": "lost"})
    with open(tmp_path / "missions.jsonl", "a") as fh:
        fh.write('{"mission_id": "W1:ff:2", "spec_h')          # killed mid-write
    assert len(read_journal(tmp_path / "missions.jsonl")) == 4
    j = Journal(tmp_path)
    assert j.done(tasks) == {tasks[0].mission_id, tasks[2].mission_id}
    assert j.done(tasks, retry_failed=True) == {tasks[0].mission_id}
    j.append({"mission_id": tasks[3].mission_id, "spec_hash": tasks[3].spec_hash, "status": "ok"})
    j.close()
    assert [r["mission_id"] for r in read_journal(tmp_path / "missions.jsonl")][-1] == tasks[3].mission_id


def test_flatten_and_tables_round_trip(tmp_path):
    import pyarrow.parquet as pq
    flat = flatten_results({"case": "W1", "rmse": {"surge": 0.1, "pitch": 0.2}, "ekf": {"rms_error": {"x": 1.5}},
                            "hs": np.float64(2.5), "series": [1, 2], "forecast": None})
    assert flat == {"result_case": "W1", "rmse_surge": 0.1, "rmse_pitch": 0.2, "ekf_rms_error_x": 1.5, "hs": 2.5,
                    "result_forecast": None}
    rows = [{"mission_id": "a", "status": "ok", "rmse_surge": 0.1 + 0.2, "n": 3},
            {"mission_id": "b", "status": "failed", "error": "ValueError: x"}]
    parquet, csv_path = write_tables(rows, tmp_path)
    back = pq.read_table(parquet).to_pylist()
    assert back[0]["rmse_surge"] == 0.1 + 0.2 and back[1]["rmse_surge"] is None and back[1]["error"] == "ValueError: x"
    assert csv_path.read_text().splitlines()[1].count(repr(0.1 + 0.2)) == 1


def test_bootstrap_ci_is_seeded_and_brackets_the_mean():
    x = np.random.default_rng(4).normal(10.0, 2.0, 40)
    lo, hi = bootstrap_ci(x, 10_000, seed=1)
    assert (lo, hi) == bootstrap_ci(x, 10_000, seed=1)
    assert lo < x.mean() < hi
    # the percentile interval of the mean is about ±1.96 s/√n for a normal sample
    half = 1.96 * x.std(ddof=1) / np.sqrt(x.size)
    assert abs((hi - lo) / 2 - half) < 0.15 * half
    assert bootstrap_ci([3.0], 500, 0) == (3.0, 3.0)
    assert all(np.isnan(bootstrap_ci([], 500, 0)))


def test_summary_pairs_seeds_with_the_baseline():
    rows = []
    for seed, (b, v) in enumerate([(1.0, 0.5), (2.0, 1.0), (1.0, 1.2)], start=1):
        for var, val in (("cpd", b), ("ff", v)):
            rows.append({"case": "W1", "variant": var, "seed": seed, "status": "ok",
                         **{f"rmse_{d}": val for d in ("surge", "heave", "pitch")},
                         **{f"max_abs_error_{d}": 3 * val for d in ("surge", "heave", "pitch")}})
    rows.append({"case": "W1", "variant": "ff", "seed": 9, "status": "failed"})
    s = summarise_campaign(rows, ["W1"], ["cpd", "ff"], "cpd", resamples=2000, seed=0)
    g = [x for x in s["groups"] if x["dof"] == "surge"]
    assert len(g) == 1 and g[0]["variant"] == "ff" and g[0]["n_seeds"] == 3
    assert g[0]["reduction_pct_mean"] == pytest.approx((50 + 50 - 20) / 3)
    assert g[0]["win_share"] == pytest.approx(2 / 3)
    assert g[0]["max_error_worst"] == pytest.approx(3.6) and g[0]["baseline_max_error_worst"] == pytest.approx(6.0)
    lo, hi = g[0]["reduction_pct_ci95"]
    assert -20 <= lo <= g[0]["reduction_pct_mean"] <= hi <= 50
    assert s["overall"]["ff"]["n_seeds"] == 3
