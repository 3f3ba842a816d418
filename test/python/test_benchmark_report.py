"""docs/benchmark.md generator: time ratios on both-solved episodes only, danger frequency, mean rows, the
beats-every-baseline verdict, the paper table reader, collisions by kind, contact speed and last decision (and
older files without those columns) and the report end to end on a synthetic results.csv."""

import csv
import math
import os

import pytest

from dqn_dovs_py import benchmark_report as br

HEADER = ["method", "obstacles", "episode", "scenario", "outcome", "time_s", "path_length_m", "min_clearance_m",
          "danger_steps", "steps", "planner_errors"]
# dqn_dovs_eval's header since the collision kinds.
HEADER_KINDS = HEADER + ["collision_kind", "contact_speed_mps"]


def write_results(path, rows, header=HEADER):
    """rows: (method, obstacles, episode, outcome, time_s, danger_steps, steps[, collision_kind, contact_speed])."""
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for m, n, k, outcome, t, danger, steps, *kind_speed in rows:
            w.writerow([m, n, k, f"1-{n}/{k}", outcome, t, 5.0, 0.5, danger, steps, 0] + kind_speed)
    return path


# Two obstacle counts, two episodes each. dqn_dovs solves (5,1), (5,2), (6,1); s_dovs solves (5,1), (6,1), (6,2).
ROWS = [
    ("dqn_dovs", 5, 1, "success", 10.0, 1, 50),
    ("dqn_dovs", 5, 2, "success", 20.0, 0, 100),
    ("dqn_dovs", 6, 1, "success", 10.0, 4, 50),
    ("dqn_dovs", 6, 2, "collision", 3.0, 5, 15),
    ("s_dovs", 5, 1, "success", 15.0, 0, 75),
    ("s_dovs", 5, 2, "timeout", 100.0, 10, 500),
    ("s_dovs", 6, 1, "success", 12.0, 2, 60),
    ("s_dovs", 6, 2, "success", 50.0, 0, 250),   # not solved by dqn_dovs: must not enter the ratio
    ("dwa", 5, 1, "collision", 2.0, 3, 10),
    ("dwa", 5, 2, "collision", 2.0, 3, 10),
    ("dwa", 6, 1, "success", 10.0, 0, 50),
    ("dwa", 6, 2, "success", 10.0, 0, 50),
    ("dqn_dovs_unshielded", 5, 1, "success", 10.0, 0, 50),
    ("dqn_dovs_unshielded", 5, 2, "success", 20.0, 0, 100),
    ("dqn_dovs_unshielded", 6, 1, "success", 10.0, 0, 50),
    ("dqn_dovs_unshielded", 6, 2, "success", 10.0, 0, 50),
]


@pytest.fixture
def records(tmp_path):
    return br.read_results(write_results(tmp_path / "results.csv", ROWS))


def test_time_ratio_uses_only_episodes_both_solved(records):
    s = br.summarize(records)
    # N = 5: only episode 1 is solved by both: 15 / 10.
    assert s.cell("s_dovs", 5).time_ratio == pytest.approx(1.5)
    assert s.cell("s_dovs", 5).both_solved == 1
    # N = 6: only episode 1 (s_dovs's episode 2 is not solved by dqn_dovs): 12 / 10.
    assert s.cell("s_dovs", 6).time_ratio == pytest.approx(1.2)
    # Overall pools every both-solved episode: (15 + 12) / (10 + 10).
    assert s.overall["s_dovs"].time_ratio == pytest.approx(27 / 20)
    assert s.overall["s_dovs"].both_solved == 2
    # dwa solves nothing at N = 5: no ratio there.
    assert math.isnan(s.cell("dwa", 5).time_ratio)
    assert s.cell("dwa", 6).time_ratio == pytest.approx(10 / 10)
    # The reference against itself.
    assert s.cell("dqn_dovs", 5).time_ratio == pytest.approx(1.0)


def test_time_ratio_matches_episodes_by_count_and_number():
    mk = lambda n, k, outcome, t: br.Record("m", n, k, outcome, t, 0, 1)  # noqa: E731
    mine = [mk(5, 1, "success", 30.0), mk(6, 1, "success", 40.0)]
    ref = [mk(5, 1, "success", 10.0), mk(6, 2, "success", 1.0)]
    ratio, both = br.time_ratio(mine, ref)
    assert both == 1 and ratio == pytest.approx(3.0)
    ratio, both = br.time_ratio(mine, [])
    assert both == 0 and math.isnan(ratio)


def test_danger_frequency_is_danger_steps_over_steps(records):
    s = br.summarize(records)
    assert s.cell("dqn_dovs", 5).danger_frequency == pytest.approx(1 / 150)
    assert s.cell("dqn_dovs", 6).danger_frequency == pytest.approx(9 / 65)
    # Pooled over episodes, not a mean of ratios.
    assert s.overall["dqn_dovs"].danger_frequency == pytest.approx(10 / 215)
    assert s.overall["s_dovs"].danger_frequency == pytest.approx(12 / 885)
    assert math.isnan(br.danger_frequency([]))


def test_rates_and_mean_row(records):
    s = br.summarize(records)
    c = s.cell("s_dovs", 5)
    assert (c.success_rate, c.collision_rate, c.timeout_rate) == (0.5, 0.0, 0.5)
    assert s.cell("dqn_dovs", 6).collision_rate == 0.5
    # The mean row averages the per-count rates.
    assert s.overall["dqn_dovs"].success_rate == pytest.approx((1.0 + 0.5) / 2)
    assert s.overall["dwa"].collision_rate == pytest.approx((1.0 + 0.0) / 2)
    assert s.cell("dqn_dovs", 5).mean_time_success_s == pytest.approx(15.0)
    assert math.isnan(s.cell("dwa", 5).mean_time_success_s)
    assert s.methods[0] == "dqn_dovs" and s.counts == [5, 6]


def test_beats_every_baseline_verdict(records):
    s = br.summarize(records)
    # N = 5: dqn_dovs 1.0, s_dovs 0.5, dwa 0.0; the unshielded ablation (1.0) is not a baseline.
    assert br.baselines_of(s) == ["s_dovs", "dwa"]
    verdict, best, rate = br.beats_every_baseline(s, 5)
    assert verdict is True and best == "s_dovs" and rate == 0.5
    # N = 6: dqn_dovs 0.5, s_dovs 1.0, dwa 1.0.
    verdict, best, rate = br.beats_every_baseline(s, 6)
    assert verdict is False and rate == 1.0
    # A tie is not a win.
    verdict, _, _ = br.beats_every_baseline(s, 5, baselines=["dqn_dovs_unshielded"])
    assert verdict is False
    # Not evaluated.
    assert br.beats_every_baseline(s, 9)[0] is None
    lines = br.stand_list(s, counts=range(5, 8))
    assert "N = 5" in lines[0] and "**beats every baseline**" in lines[0]
    assert "N = 6" in lines[1] and "does **not**" in lines[1]
    assert "N = 7: not evaluated" in lines[2]
    assert "1 of 2" in lines[-1]


def test_reference_must_be_present(tmp_path):
    recs = br.read_results(write_results(tmp_path / "r.csv", [r for r in ROWS if r[0] != "dqn_dovs"]))
    with pytest.raises(ValueError, match="dqn_dovs"):
        br.summarize(recs)


def test_malformed_row_names_file_and_line(tmp_path):
    path = write_results(tmp_path / "bad.csv", ROWS[:2])
    with open(path, "a") as f:
        f.write("dqn_dovs,x,1,1-5/1,success,1,1,1,0,1,0\n")
    with pytest.raises(ValueError, match=r"bad\.csv:4"):
        br.read_results(path)


def test_read_paper_skips_comments(tmp_path):
    p = tmp_path / "paper.csv"
    p.write_text("# comment, with a comma\nobstacles,dqn_dovs,s_dovs,s_dovs_time_ratio,orca\n"
                 "5,0.82,0.73,1.07,0.76\n6,0.80,0.71,1.06,0.65\n")
    paper = br.read_paper(str(p))
    assert paper["dqn_dovs"] == {5: 0.82, 6: 0.80}
    assert paper["s_dovs_time_ratio"][6] == 1.06
    table = br.success_table(br.summarize([br.Record("dqn_dovs", 5, 1, "success", 1.0, 0, 1)]), paper)
    assert "paper s_dovs" in table and "0.73 (1.07)" in table and "paper s_dovs_time_ratio" not in table


def test_report_end_to_end(tmp_path):
    tracker = write_results(tmp_path / "tracker.csv", ROWS)
    perfect = write_results(tmp_path / "perfect.csv", [r[:3] + ("success",) + r[4:] for r in ROWS])
    paper = tmp_path / "paper.csv"
    paper.write_text("obstacles,dqn_dovs,s_dovs,s_dovs_time_ratio,orca\n5,0.82,0.73,1.07,0.76\n"
                     "6,0.80,0.71,1.06,0.65\n")
    discussion = tmp_path / "discussion.md"
    discussion.write_text("Hand-written *prose*, kept verbatim.\n\n- a point\n")
    # The repository's layout: the report in docs/, its data and plots in results/benchmark/.
    out = tmp_path / "docs" / "benchmark.md"
    out.parent.mkdir()
    plots = tmp_path / "results" / "benchmark"
    rc = br.main(["--tracker", str(tracker), "--perfect", str(perfect), "--paper", str(paper),
                  "--discussion", str(discussion), "--run-info", str(tmp_path / "missing.json"),
                  "--plots", str(plots), "--out", str(out)])
    assert rc == 0
    text = out.read_text()
    assert "Hand-written *prose*, kept verbatim.\n\n- a point\n" in text
    assert "## Where we stand" in text and "**Perfect information**" in text
    # No oracle in these files: its column says so, before the paper's.
    assert "| 5 | 1.00 | 0.50 (1.50) | 0.00 (-) | 1.00 (1.00) | not run | 0.82 | 0.73 (1.07) | 0.76 |" in text
    for png in ("success_vs_n_tracker.png", "success_vs_n_perfect.png", "collision_vs_n.png"):
        assert os.path.getsize(plots / png) > 1000
        assert f"(../results/benchmark/{png})" in text
    assert "not recorded" in text


def test_report_without_perfect_run(tmp_path):
    tracker = write_results(tmp_path / "tracker.csv", ROWS)
    out = tmp_path / "benchmark.md"
    rc = br.main(["--tracker", str(tracker), "--perfect", str(tmp_path / "none.csv"), "--paper", "",
                  "--discussion", "", "--run-info", "", "--plots", str(tmp_path), "--out", str(out)])
    assert rc == 0
    assert "## Perfect information\n\nNot run" in out.read_text()


def test_sign_test_p_values():
    assert br.sign_test_p(0, 0) == 1.0
    assert br.sign_test_p(1, 0) == 1.0
    assert br.sign_test_p(5, 0) == pytest.approx(2 / 32)
    assert br.sign_test_p(8, 2) == pytest.approx(2 * (1 + 10 + 45) / 1024)
    assert br.sign_test_p(2, 8) == br.sign_test_p(8, 2)
    assert br.sign_test_p(10, 0) == pytest.approx(2 / 1024)
    assert br.sign_test_p(6, 6) == 1.0


def test_paired_comparison_counts_discordant_episodes(records):
    vs_sdovs = br.paired_comparison(records, "dqn_dovs", "s_dovs")
    assert (vs_sdovs[5].episodes, vs_sdovs[5].wins, vs_sdovs[5].losses) == (2, 1, 0)  # (5,2): s_dovs timed out
    assert (vs_sdovs[6].episodes, vs_sdovs[6].wins, vs_sdovs[6].losses) == (2, 0, 1)  # (6,2): dqn_dovs collided
    assert (vs_sdovs[None].episodes, vs_sdovs[None].wins, vs_sdovs[None].losses) == (4, 1, 1)
    assert vs_sdovs[None].p_value == 1.0
    vs_dwa = br.paired_comparison(records, "dqn_dovs", "dwa")
    assert (vs_dwa[None].wins, vs_dwa[None].losses) == (2, 1)
    assert vs_dwa[5].p_value == pytest.approx(0.5)
    # Episodes only one method ran are not paired.
    partial = [r for r in records if not (r.method == "dwa" and r.obstacles == 6)]
    assert 6 not in br.paired_comparison(partial, "dqn_dovs", "dwa")


def test_report_has_the_paired_table(tmp_path):
    tracker = write_results(tmp_path / "tracker.csv", ROWS)
    out = tmp_path / "benchmark.md"
    assert br.main(["--tracker", str(tracker), "--perfect", "", "--paper", "", "--discussion", "", "--run-info", "",
                    "--plots", str(tmp_path), "--out", str(out)]) == 0
    text = out.read_text()
    assert "### Paired comparison" in text
    assert "| N | vs s_dovs | vs dwa |" in text
    assert "| 5 | +1 / -0 (1) | +2 / -0 (0.5) |" in text
    assert "| all | +1 / -1 (1) | +2 / -1 (1) |" in text
    assert "- vs s_dovs: pooled +1 / -1 of 4 paired episodes, p = 1 (no significant difference)" in text


# The same two counts with the collision kinds and contact speeds recorded.
KIND_ROWS = [
    ("dqn_dovs", 5, 1, "collision", 3.0, 5, 15, "rest", 0.01),
    ("dqn_dovs", 5, 2, "success", 10.0, 0, 50, "", ""),
    ("dqn_dovs", 6, 1, "collision", 3.0, 5, 15, "moving", 0.4),
    ("dqn_dovs", 6, 2, "collision", 3.0, 5, 15, "moving", 0.8),
    ("s_dovs", 5, 1, "collision", 3.0, 5, 15, "static", 0.3),
    ("s_dovs", 5, 2, "timeout", 100.0, 0, 500, "", ""),
    ("s_dovs", 6, 1, "success", 10.0, 0, 50, "", ""),
    ("s_dovs", 6, 2, "success", 10.0, 0, 50, "", ""),
]


def test_nearest_rank_percentile():
    assert math.isnan(br.nearest_rank([], 0.95))
    assert br.nearest_rank([0.7], 0.95) == 0.7
    assert br.nearest_rank([0.8, 0.4], 0.95) == 0.8  # rank ceil(1.9) = 2, not interpolated (0.78)
    assert br.nearest_rank(list(range(1, 21)), 0.95) == 19  # ceil(19) = 19
    assert br.nearest_rank(list(range(21, 0, -1)), 0.95) == 20  # ceil(19.95) = 20, order does not matter


def test_collisions_by_kind_and_contact_speed(tmp_path):
    recs = br.read_results(write_results(tmp_path / "results.csv", KIND_ROWS, HEADER_KINDS))
    assert recs[0].collision_kind == "rest" and recs[0].contact_speed_mps == 0.01
    assert recs[1].collision_kind == "" and math.isnan(recs[1].contact_speed_mps)
    s = br.summarize(recs)
    assert s.cell("dqn_dovs", 5).collisions_by_kind == {"static": 0, "rest": 1, "moving": 0}
    assert s.cell("dqn_dovs", 6).collisions_by_kind == {"static": 0, "rest": 0, "moving": 2}
    assert s.cell("dqn_dovs", 6).mean_contact_speed_mps == pytest.approx(0.6)
    assert s.cell("dqn_dovs", 6).p95_contact_speed_mps == 0.8
    # Pooled over every count: summed counts, speeds over all three collisions.
    o = s.overall["dqn_dovs"]
    assert o.collisions_by_kind == {"static": 0, "rest": 1, "moving": 2}
    assert o.mean_contact_speed_mps == pytest.approx(1.21 / 3)
    assert o.p95_contact_speed_mps == 0.8
    assert s.cell("s_dovs", 6).collisions_by_kind == {"static": 0, "rest": 0, "moving": 0}
    assert math.isnan(s.cell("s_dovs", 6).mean_contact_speed_mps)
    assert math.isnan(s.cell("s_dovs", 6).p95_contact_speed_mps)

    kinds = br.collision_kind_table(s).splitlines()
    assert kinds[0] == "| N | dqn_dovs | s_dovs |"
    assert kinds[2:] == ["| 5 | 0 / 1 / 0 | 1 / 0 / 0 |", "| 6 | 0 / 0 / 2 | 0 / 0 / 0 |",
                         "| all | 0 / 1 / 2 | 1 / 0 / 0 |"]
    speeds = br.contact_speed_table(s).splitlines()
    assert speeds[2:] == ["| 5 | 0.010 (0.010) | 0.300 (0.300) |", "| 6 | 0.600 (0.800) | - |",
                          "| all | 0.403 (0.800) | 0.300 (0.300) |"]


def test_collisions_by_last_decision(tmp_path):
    header = HEADER_KINDS + ["last_decision"]
    rows = [
        ("dqn_dovs", 5, 1, "collision", 3.0, 5, 15, "rest", 0.01, "escape (shield: latest; rest)"),
        ("dqn_dovs", 5, 2, "collision", 3.0, 5, 15, "moving", 0.3, "escape (shield: latest; slowest)"),
        ("dqn_dovs", 6, 1, "collision", 3.0, 5, 15, "moving", 0.2, "action 3 (shield: robust)"),
        ("dqn_dovs", 6, 2, "collision", 3.0, 5, 15, "rest", 0.0, "escape (shield: latest; rest)"),
        ("dqn_dovs", 7, 1, "success", 3.0, 5, 15, "", "", "action 4 (shield: robust)"),  # not a collision
        ("s_dovs", 5, 1, "collision", 3.0, 5, 15, "static", 0.4, "escape: corner"),  # another planner's note
        ("s_dovs", 5, 2, "collision", 3.0, 5, 15, "rest", 0.0, ""),  # before the first decision
    ]
    recs = br.read_results(write_results(tmp_path / "r.csv", rows, header))
    assert recs[0].last_decision == "escape (shield: latest; rest)"
    assert br.decision_category("action 7") == "action"
    assert br.decision_category("decelerate: every action is masked") == "decelerate"
    table = br.last_decision_table(recs, ["dqn_dovs", "s_dovs"]).splitlines()
    assert table[0] == "| last decision | dqn_dovs | s_dovs |"
    # Rows by number of collisions (ties in first-seen order); cells rest / moving / static.
    assert table[2:] == ["| escape: rest (shield latest) | 2 / 0 / 0 | - |",
                         "| escape: slowest (shield latest) | 0 / 1 / 0 | - |",
                         "| action (shield robust) | 0 / 1 / 0 | - |",
                         "| escape: corner | - | 0 / 0 / 1 |",
                         "| before the first decision | - | 1 / 0 / 0 |"]
    # Files from before the column: no table.
    assert br.last_decision_table(br.read_results(write_results(tmp_path / "o.csv", KIND_ROWS, HEADER_KINDS)),
                                  ["dqn_dovs"]) is None


def test_unclassified_collision_counts_in_no_kind(tmp_path):
    # A collision dqn_dovs_eval could not classify (empty kind, no speed) is a collision of no kind, as in eval.cpp.
    rows = [("dqn_dovs", 5, 1, "collision", 3.0, 5, 15, "", ""), ("dqn_dovs", 5, 2, "collision", 3.0, 5, 15,
                                                                   "moving", 0.5)]
    c = br.summarize(br.read_results(write_results(tmp_path / "r.csv", rows, HEADER_KINDS))).cell("dqn_dovs", 5)
    assert c.collisions == 2 and c.collisions_by_kind == {"static": 0, "rest": 0, "moving": 1}
    assert c.mean_contact_speed_mps == 0.5 and c.p95_contact_speed_mps == 0.5


def test_unknown_collision_kind_names_file_and_line(tmp_path):
    rows = KIND_ROWS[:1] + [("dqn_dovs", 5, 2, "collision", 3.0, 5, 15, "sideways", 0.2)]
    with pytest.raises(ValueError, match=r"kinds\.csv:3: unknown collision_kind 'sideways'"):
        br.read_results(write_results(tmp_path / "kinds.csv", rows, HEADER_KINDS))


def test_older_results_without_kinds_read_as_not_recorded(records):
    assert all(r.collision_kind is None and math.isnan(r.contact_speed_mps) for r in records)
    s = br.summarize(records)
    # Cells with collisions: kinds unknown; cells without: nothing to classify.
    assert s.cell("dqn_dovs", 6).collisions_by_kind is None
    assert s.cell("dqn_dovs", 5).collisions_by_kind == {"static": 0, "rest": 0, "moving": 0}
    assert s.overall["dqn_dovs"].collisions_by_kind is None
    assert math.isnan(s.overall["dqn_dovs"].mean_contact_speed_mps)
    kinds = br.collision_kind_table(s)
    assert "| 5 | 0 / 0 / 0 | 0 / 0 / 0 | - | 0 / 0 / 0 |" in kinds
    assert "| all | - | 0 / 0 / 0 | - | 0 / 0 / 0 |" in kinds
    assert "| all | - | - | - | - |" in br.contact_speed_table(s)


def test_report_has_the_collision_kind_tables(tmp_path):
    tracker = write_results(tmp_path / "tracker.csv", KIND_ROWS, HEADER_KINDS)
    perfect = write_results(tmp_path / "perfect.csv", ROWS)  # an older file: kinds not recorded
    out = tmp_path / "benchmark.md"
    assert br.main(["--tracker", str(tracker), "--perfect", str(perfect), "--paper", "", "--discussion", "",
                    "--run-info", "", "--plots", str(tmp_path), "--out", str(out)]) == 0
    text = out.read_text()
    tracker_part, perfect_part = text.split("## Tracker in the loop")[1].split("## Perfect information")
    for part in (tracker_part, perfect_part):
        assert "### Collisions by kind\n\nCounts, static / rest / moving:" in part
        assert "### Robot speed at contact (m/s)\n\nThe robot's linear speed" in part
    assert "| all | 0 / 1 / 2 | 1 / 0 / 0 |" in tracker_part
    assert "| all | 0.403 (0.800) | 0.300 (0.300) |" in tracker_part
    assert "| all | - | 0 / 0 / 0 | - | 0 / 0 / 0 |" in perfect_part
    # The rate tables keep their mean row (collision rate: mean of 0.5 and 1.0, of 0.5 and 0.0).
    assert "| mean | 0.75 | 0.25 |" in tracker_part


# With the oracle (its rows first in the file, as they may come in any order), collision kinds recorded. N = 5:
# oracle solves 1-3 and is walked into at rest on 4 (no method solves 4); N = 6: oracle solves 1-3 and times out on
# 4, which dqn_dovs solves. dqn_dovs solves (5,1), (5,2), (6,1), (6,4); s_dovs (5,1), (6,3).
def _oracle_rows():
    rows = [("oracle", 5, k, "success", 8.0, 0, 40, "", "") for k in (1, 2, 3)]
    rows += [("oracle", 5, 4, "collision", 6.0, 3, 30, "rest", 0.0)]
    rows += [("oracle", 6, k, "success", 8.0, 0, 40, "", "") for k in (1, 2, 3)]
    rows += [("oracle", 6, 4, "timeout", 100.0, 0, 500, "", "")]
    solved = {"dqn_dovs": {(5, 1), (5, 2), (6, 1), (6, 4)}, "s_dovs": {(5, 1), (6, 3)}}
    for m, ok in solved.items():
        for n in (5, 6):
            for k in (1, 2, 3, 4):
                rows.append((m, n, k, "success", 10.0, 0, 50, "", "") if (n, k) in ok else
                            (m, n, k, "collision", 3.0, 2, 15, "moving", 0.5))
    return rows


ORACLE_ROWS = _oracle_rows()


@pytest.fixture
def oracle_records(tmp_path):
    return br.read_results(write_results(tmp_path / "oracle.csv", ORACLE_ROWS, HEADER_KINDS))


def test_oracle_is_a_ceiling_not_a_baseline(oracle_records, tmp_path_factory):
    s = br.summarize(oracle_records)
    assert s.methods == ["dqn_dovs", "s_dovs", "oracle"]  # the oracle last although its rows come first
    assert br.has_oracle(s) and br.baselines_of(s) == ["s_dovs"]
    # Nor is the reachability bound, the limit from above.
    bound_rows = [("bound", n, k, "success", 7.0, 0, 35, "", "") for n in (5, 6) for k in (1, 2, 3, 4)]
    with_bound = br.summarize(oracle_records + br.read_results(
        write_results(tmp_path_factory.mktemp("bound") / "bound.csv", bound_rows, HEADER_KINDS)))
    assert "bound" in with_bound.methods and br.baselines_of(with_bound) == ["s_dovs"]
    # The oracle (0.75) is above dqn_dovs (0.50) at both counts; against the baselines dqn_dovs still wins.
    assert br.beats_every_baseline(s, 5) == (True, "s_dovs", 0.25)
    assert all("**beats every baseline**" in line for line in br.stand_list(s, counts=(5, 6))[:2])
    table, lines = br.paired_table(oracle_records, s)
    assert table.splitlines()[0] == "| N | vs s_dovs |" and "oracle" not in "\n".join(lines)
    # The success table: the oracle's column last, with its time ratio against dqn_dovs (8 / 10 on (5,1), (5,2)).
    rows = br.success_table(s, None).splitlines()
    assert rows[0] == "| N | dqn_dovs | s_dovs | oracle |"
    assert rows[2] == "| 5 | 0.50 | 0.25 (1.00) | 0.75 (0.80) |"
    assert rows[4] == "| mean | 0.50 | 0.25 (1.00) | 0.75 (0.80) |"


def test_oracle_share_and_unsolved_episodes(oracle_records):
    s = br.summarize(oracle_records)
    share = br.oracle_share_table(s).splitlines()
    assert share[0] == "| N | oracle success | dqn_dovs | s_dovs | oracle unsolved (collisions / timeouts) |"
    # N = 5: 2 and 1 of the oracle's 3; N = 6: 2 and 1 of 3; all: 4 and 2 of 6 pooled.
    assert share[2:] == ["| 5 | 0.75 | 0.67 | 0.33 | 1 / 0 |", "| 6 | 0.75 | 0.67 | 0.33 | 0 / 1 |",
                         "| all | 0.75 | 0.67 | 0.33 | 1 / 1 |"]
    unsolved = br.oracle_unsolved(oracle_records)
    assert [(u.obstacles, u.episode, u.scenario, u.outcome_text(), u.solved_by) for u in unsolved] == [
        (5, 4, "1-5/4", "collision, robot at rest", []), (6, 4, "1-6/4", "timeout", ["dqn_dovs"])]
    assert br.unsolved_counts(unsolved) == ("1 collision (1 robot at rest, 0 robot moving, 0 static geometry), "
                                            "1 timeout")
    assert br.unsolved_table(unsolved).splitlines()[2:] == [
        "| 5 | 4 | `1-5/4` | collision, robot at rest | 6.0 | none |",
        "| 6 | 4 | `1-6/4` | timeout | 100.0 | dqn_dovs |"]
    # Files without an oracle: nothing unsolved, no share.
    plain = [r for r in oracle_records if r.method != "oracle"]
    assert br.oracle_unsolved(plain) == [] and not br.has_oracle(br.summarize(plain))


def _report(tmp_path, tracker, perfect="", bound=""):
    out = tmp_path / "benchmark.md"
    assert br.main(["--tracker", str(tracker), "--perfect", str(perfect), "--paper", "", "--discussion", "",
                    "--run-info", "", "--plots", str(tmp_path), "--out", str(out), "--bound", str(bound)]) == 0
    return out.read_text()


def test_the_bound_says_which_episodes_no_robot_can_solve(tmp_path):
    tracker = write_results(tmp_path / "tracker.csv", ORACLE_ROWS, HEADER_KINDS)
    # Without the bound's run: its section says so.
    assert "Not run: no `bound` results" in _report(tmp_path, tracker)
    # Every episode reachable after 7 s but (5, 4), where a collision is certain by 6 s: every method collided
    # there by then, and each success came later than 7 s or at 8 s (the oracle) - inside the bound.
    rows = [("bound", n, k, "success", 7.0, 0, 35, "", "") for n in (5, 6) for k in (1, 2, 3, 4) if (n, k) != (5, 4)]
    bound = write_results(tmp_path / "bound.csv", rows + [("bound", 5, 4, "collision", 6.0, 0, 30, "", "")],
                          HEADER_KINDS)
    text = _report(tmp_path, tracker, bound=bound)
    section = text.split("## Episodes no robot can solve: the reachability bound")[1].split("## Discussion")[0]
    assert "| 5 | 4 | 0.75 | 1 | 0 |" in section and "| all | 8 | 0.88 | 1 | 0 |" in section
    assert "- tracker in the loop: no success of `oracle`, `dqn_dovs`, `s_dovs` lies outside the bound" in section
    # A bound that put (6, 4) out of reach and (5, 1) at 9 s would be broken by dqn_dovs (it solved (6, 4)) and by
    # the oracle (at 8 s on (5, 1)): the report says so.
    rows = [r if (r[1], r[2]) not in ((6, 4), (5, 1)) else
            (r[:3] + ("timeout", 100.0, 0, 500, "", "") if r[1] == 6 else r[:4] + (9.0,) + r[5:]) for r in rows]
    bound = write_results(tmp_path / "bound.csv", rows + [("bound", 5, 4, "collision", 6.0, 0, 30, "", "")],
                          HEADER_KINDS)
    section = _report(tmp_path, tracker, bound=bound).split("reachability bound")[1]
    assert "**outside the bound**" in section
    assert "`oracle` 1 successes it rules out or sooner, 0 certain collisions avoided" in section
    assert "`dqn_dovs` 1 successes it rules out or sooner" in section and "`s_dovs`" not in section.split("\n- ")[1]
    # A method that survived a certain collision is named too; the holonomic baseline (another robot) is not checked.
    survived = [("s_dovs", 5, 4, "success", 12.0, 0, 60, "", ""), ("orca_holonomic", 6, 4, "success", 5.0, 0, 25, "", "")]
    records = br.read_results(write_results(tmp_path / "survived.csv", survived, HEADER_KINDS))
    assert br.beyond_bound(br.read_results(bound), records) == {"s_dovs": (1, 1)}


def test_report_with_the_oracle(tmp_path):
    tracker = write_results(tmp_path / "tracker.csv", ORACLE_ROWS, HEADER_KINDS)
    # Perfect information: every planner solves everything, the oracle's outcomes are the same.
    perfect = write_results(tmp_path / "perfect.csv", [r if r[0] == "oracle" else
                                                       r[:3] + ("success", 10.0, 0, 50, "", "") for r in ORACLE_ROWS],
                            HEADER_KINDS)
    text = _report(tmp_path, tracker, perfect)
    tracker_part, perfect_part = text.split("## Perfect information")
    assert "| 6 | 0.50 | 0.25 (-) | 0.75 (0.80) |" in tracker_part
    assert "| all | 0.75 | 0.67 | 0.33 | 1 / 1 |" in tracker_part
    assert ("- 2 of the oracle's 8 episodes unsolved: 1 collision (1 robot at rest, 0 robot moving, 0 static "
            "geometry), 1 timeout; 1 of them solved by another method, the others by none.") in tracker_part
    assert "| 5 | 4 | `1-5/4` | collision, robot at rest | 6.0 | none |" in tracker_part
    # With perfect information both planners solve the oracle's two failures, and more than its successes.
    assert "| all | 0.75 | 1.33 | 1.33 | 1 / 1 |" in perfect_part
    assert "| 5 | 4 | `1-5/4` | collision, robot at rest | 6.0 | dqn_dovs, s_dovs |" in perfect_part
    assert "2 of them solved by another method" in perfect_part
    assert "vs oracle" not in text and "The first" not in text


def test_the_unsolved_list_is_cut_with_a_pointer_to_the_file(tmp_path, monkeypatch):
    monkeypatch.setattr(br, "MAX_UNSOLVED_ROWS", 1)
    tracker = write_results(tmp_path / "tracker.csv", ORACLE_ROWS, HEADER_KINDS)
    text = _report(tmp_path, tracker)
    assert "| 5 | 4 | `1-5/4` |" in text and "| 6 | 4 | `1-6/4` |" not in text
    assert f"The first 1 of 2; every one: the `oracle` rows of `{tracker}` whose outcome is not success." in text


def test_report_of_a_run_without_the_oracle(tmp_path):
    text = _report(tmp_path, write_results(tmp_path / "tracker.csv", ROWS))
    assert "| N | dqn_dovs | s_dovs | dwa | dqn_dovs_unshielded | oracle |" in text
    assert "| mean | 0.75 | 0.75 (1.35) | 0.50 (1.00) | 1.00 (1.00) | not run |" in text
    assert "### Share of the oracle's successes\n\nNot run: no `oracle` episodes in this run" in text
    assert "### Episodes the oracle did not solve" not in text
