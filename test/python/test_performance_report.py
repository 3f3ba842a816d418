"""docs/performance.md generator: missing benchmarks are 'not measured', peak memory from GNU time's output,
evaluation throughput, and the figures land beside their commands."""

import json

from dqn_dovs_py import performance_report as pr

BENCHES = ["sim", "env", "tracker", "dovs", "inference", "training", "e2e", "eval-sdovs", "eval-dqn"]


def write(tmp_path, name, figures=None, rss=None, load=None):
    if figures is not None:
        (tmp_path / f"{name}.json").write_text(json.dumps(figures))
    if rss is not None:
        (tmp_path / f"{name}.rss_kb").write_text(rss)
    if load is not None:
        (tmp_path / f"{name}.loadavg").write_text(load)


def test_missing_results_are_not_measured(tmp_path):
    out = tmp_path / "performance.md"
    assert pr.main(["--results", str(tmp_path / "none"), "--out", str(out)]) == 0
    text = out.read_text()
    for b in BENCHES:
        assert f"| {b} | not measured |" in text
    assert "Not measured: " + ", ".join(BENCHES) in text


def test_figures_rss_and_throughput(tmp_path):
    write(tmp_path, "sim", {"steps_per_s": 18979.9, "step_us_median": 3.35, "scan_us_median": 26.4,
                            "scan_us_p95": 37.6}, rss="52680\n", load="0.50 0.40 0.30\n")
    write(tmp_path, "inference", {"decision_us_median": 58.4, "decision_us_p99": 70.2, "decision_us_max": 99.0},
          rss="Command exited with non-zero status 1\n2048\n")
    write(tmp_path, "eval-dqn", {"success_mean": 0.8, "episodes_per_count": 10, "episodes": 300, "wall_s": 20.0})
    write(tmp_path, "eval-sdovs", {"success_mean": 0.8, "episodes_per_count": 4, "wall_s": 6.0})
    figures, rss, _ = pr.load_results(str(tmp_path), BENCHES)
    assert set(figures) == {"sim", "inference", "eval-dqn", "eval-sdovs"}
    assert rss == {"sim": 52680.0, "inference": 2048.0}
    assert pr.eval_throughput(figures, "eval-dqn") == (300.0, 15.0)
    assert pr.eval_throughput(figures, "eval-sdovs") == (60.0, 10.0)  # 15 counts x 4 episodes, one method
    assert pr.eval_throughput(figures, "eval-missing") is None
    out = tmp_path / "performance.md"
    assert pr.main(["--results", str(tmp_path), "--out", str(out), "--benches", ",".join(BENCHES)]) == 0
    text = out.read_text()
    assert "| world steps per second (one 720-beam scan per step, 15 obstacles) | 18,980 1/s | `make bench-sim` |" \
        in text
    assert "| Q-network decision, qValues + masked argmax (wall clock) | p99 | 70.2 us | `make bench-inference` |" in text
    assert "| sim | 51.4 MiB | `make bench-sim` |" in text
    assert "| inference | 2.0 MiB | `make bench-inference` |" in text
    assert "| tracker | not measured | `make bench-tracker` |" in text
    assert "| eval-dqn | dqn_dovs + s_dovs | 10 | 300 | 20.0 s | 15.0 | `make bench-eval-dqn` |" in text
    assert "0.50 / 0.40 / 0.30" in text
    assert "nproc" in text and "Not measured: env, tracker, dovs, training, e2e" in text


def test_hand_written_notes_and_the_nodelet_rows(tmp_path):
    write(tmp_path, "e2e", {"latency_ms_median": 1.4, "latency_ms_p99": 2.9, "latency_ms_max": 4.5,
                            "nodelets_latency_ms_median": 1.2, "nodelets_latency_ms_p99": 2.8,
                            "nodelets_latency_ms_max": 4.4})
    notes = tmp_path / "notes.md"
    notes.write_text("<!-- a comment for whoever edits it -->\n**A note** on these figures.\n")
    out = tmp_path / "performance.md"
    assert pr.main(["--results", str(tmp_path), "--out", str(out), "--notes", str(notes)]) == 0
    text = out.read_text()
    assert "### Measurement notes\n\n**A note** on these figures." in text
    assert "a comment for whoever edits it" not in text
    assert "| end to end: scan stamp -> action (ROS nodes) | p99 | 2.9 ms | `make bench-e2e` |" in text
    assert "| end to end: scan stamp -> action (nodelets) | p99 | 2.8 ms | `make bench-e2e` |" in text
    # Without a notes file the section is left out.
    assert pr.main(["--results", str(tmp_path), "--out", str(out), "--notes", str(tmp_path / "none.md")]) == 0
    assert "Measurement notes" not in out.read_text()
