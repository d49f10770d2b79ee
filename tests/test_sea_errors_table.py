"""benchmarks.sea_errors: the paired reductions, the "worse" flag and the table from a campaign folder."""
from __future__ import annotations

import json

import pytest

from benchmarks.sea_errors import markdown, sea_errors

COLUMNS = ["case", "variant", "seed", "status", "rmse_surge", "rmse_heave", "rmse_pitch"]


def _folder(tmp_path, rows):
    camp = {"name": "sea_errors", "cases": ["W1"], "baseline": "cpd",
            "variants": [{"name": "cpd"}, {"name": "ff_exact", "baseline": None},
                         {"name": "cpd_bar30"}, {"name": "ff_bar30_raw", "baseline": "cpd_bar30"}]}
    (tmp_path / "campaign.json").write_text(json.dumps(camp))
    with open(tmp_path / "missions.jsonl", "w") as fh:
        for r in rows:
            row = dict(zip(COLUMNS, r, strict=True))
            row["mission_id"] = f"{row['case']}:{row['variant']}:{row['seed']}"
            fh.write(json.dumps(row) + "\n")
    return tmp_path


def test_each_row_is_paired_by_seed_with_its_own_baseline(tmp_path):
    rows = [("W1", "cpd", s, "ok", 1.0, 1.0, 0.1) for s in (1, 2, 3)]
    rows += [("W1", "ff_exact", 1, "ok", 0.5, 0.5, 0.05), ("W1", "ff_exact", 2, "ok", 0.25, 0.5, 0.05),
             ("W1", "ff_exact", 3, "failed", "", "", "")]
    rows += [("W1", "cpd_bar30", s, "ok", 2.0, 2.0, 0.2) for s in (1, 2)]
    rows += [("W1", "ff_bar30_raw", s, "ok", 1.0, 2.0, 0.22) for s in (1, 2)]
    doc = sea_errors(_folder(tmp_path, rows), resamples=200)
    by = {r["variant"]: r["cases"]["W1"] for r in doc["rows"]}
    ff = by["ff_exact"]
    # seed 1: (50 + 50 + 50)/3; seed 2: (75 + 50 + 50)/3; the failed seed 3 is left out
    assert ff["seeds"] == 2 and ff["reduction_pct_mean"] == pytest.approx((50.0 + 175.0 / 3) / 2)
    assert ff["worse_in"] == [] and ff["share_of_seeds_won"] == 1.0
    raw = by["ff_bar30_raw"]          # against cpd_bar30, not cpd: surge 50 %, heave 0 %, pitch −10 %
    assert raw["reduction_pct_mean"] == pytest.approx(40.0 / 3) and raw["worse_in"] == ["pitch"]
    assert doc["ff_never_worse_in_mean_rmse"] == {"pass": False, "failures": ["ff_bar30_raw W1: pitch"]}
    table = markdown(doc)
    assert "| exact forecast | 54.2 % [" in table and "(2 seeds)" in table and "| W1 pitch |" in table
