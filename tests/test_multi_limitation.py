"""Paper 1, experiment 3 (Fig. 9): the outcome the paper reports, through the CLI's JSON."""

from __future__ import annotations

import json

from cobotsafety.cli import main


def test_fig9_outcome(tmp_path, capsys):
    assert main(["experiment", "multi-limitation", "--json", "--out", str(tmp_path)]) == 0
    results = {(r["scenario"], r["method"]): r for r in json.loads(capsys.readouterr().out)}
    assert set(results) == {(s, m) for s in "ab" for m in ("anticipative", "reactive", "stop")}
    # a: the zones are connected, every method ends at the zone.
    for method in ("anticipative", "reactive", "stop"):
        assert results["a", method]["reached"] is False
        assert results["a", method]["time_s"] is None
        assert results["a", method]["min_clearance_m"] < 0.05
    # b: the anticipative method slides through the gap; reactive stalls at the triangle; stop stops.
    assert results["b", "anticipative"]["reached"] is True
    assert 0 < results["b", "anticipative"]["time_s"] < 10
    assert results["b", "reactive"]["reached"] is False
    assert results["b", "stop"]["reached"] is False
    # No method penetrates any zone.
    assert all(r["min_clearance_m"] >= -1e-9 for r in results.values())
    assert (tmp_path / "fig9_a.png").stat().st_size > 10_000
    assert (tmp_path / "fig9_b.png").stat().st_size > 10_000
