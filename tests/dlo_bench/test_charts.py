"""The benchmark's bar charts tell every agent apart."""
import pytest

from dlo_bench.charts import _bar_style, plot_results


def test_every_agent_of_twenty_has_its_own_bar_style():
    styles = {(s["color"], s.get("hatch")) for s in map(_bar_style, range(20))}
    assert len(styles) == 20


def test_plot_results_draws_twelve_agents(tmp_path):
    pytest.importorskip("matplotlib")
    rows = [{"agent": f"agent-{i}", "env": "endpoint", "cell": "d1", "difficulty": 1,
             "suite": "linear-1", "threshold": 0.01, "status": "ok", "success_rate": i / 12,
             "median_rest_error": 0.01, "seconds_per_episode": 0.1} for i in range(12)]
    png = tmp_path / "results.png"
    plot_results(rows, png)
    assert png.stat().st_size > 10_000
