"""python -m dqn_dovs_py.paired_results: evaluation runs of the same episodes compared pairwise with the sign test."""

from __future__ import annotations

import re

import pytest

from dqn_dovs_py import paired_results
from dqn_dovs_py.benchmark_report import sign_test_p

HEADER = "method,obstacles,episode,outcome,time_s,danger_steps,steps\n"


def write_run(path, outcomes, method="dqn_dovs"):
    """outcomes: {(obstacles, episode): outcome}."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(HEADER + "".join(f"{method},{n},{k},{o},10.0,0,50\n" for (n, k), o in sorted(outcomes.items())))
    return path


def test_runs_are_compared_episode_by_episode(tmp_path, capsys):
    base = {(5, k): "success" if k < 6 else "collision" for k in range(10)}
    base.update({(10, k): "success" if k < 3 else "timeout" for k in range(10)})
    # The variant solves 3 more at N = 5 and loses 1, and at N = 10 loses 2; episode (10, 9) is missing.
    variant = dict(base)
    variant.update({(5, 6): "success", (5, 7): "success", (5, 8): "success", (5, 0): "collision",
                    (10, 0): "collision", (10, 1): "timeout"})
    del variant[(10, 9)]
    a = write_run(tmp_path / "a" / "results.csv", base)
    write_run(tmp_path / "b" / "results.csv", variant)
    out = tmp_path / "paired.md"
    assert paired_results.main([f"base={a}", f"tol={tmp_path / 'b'}", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert text == out.read_text()
    rows = {tuple(c.strip() for c in line.split("|")[1:3]): [c.strip() for c in line.split("|")[3:-1]]
            for line in text.splitlines()[2:]}
    assert rows[("base", "all")][:3] == ["20", "0.450", "4"]
    assert rows[("tol", "5")] == ["10", "0.800", "2", f"+3 / -1, p = {sign_test_p(3, 1):.2g} (10 paired)"]
    assert rows[("tol", "10")][:3] == ["9", "0.111", "1"]
    assert rows[("tol", "all")][3] == f"+3 / -3, p = {sign_test_p(3, 3):.2g} (19 paired)"


def test_a_method_is_picked_from_a_file_of_several(tmp_path, capsys):
    path = tmp_path / "both.csv"
    path.write_text(HEADER + "dqn_dovs,5,0,success,1,0,5\ns_dovs,5,0,collision,1,0,5\n")
    other = write_run(tmp_path / "o.csv", {(5, 0): "collision"})
    assert paired_results.main([f"a={path}", f"b={other}"]) == 2
    assert "holds several methods (dqn_dovs, s_dovs); pick one with --method" in capsys.readouterr().err
    assert paired_results.main([f"a={path}", f"b={other}", "--method", "dqn_dovs"]) == 0
    assert "+0 / -1" in capsys.readouterr().out


@pytest.mark.parametrize("args, message", [
    (["a=x.csv"], "at least two runs"),
    (["a", "b=y"], "'a': expected NAME=results.csv"),
    (["a=/nonexistent/r.csv", "b=/nonexistent/s.csv"], "/nonexistent/r.csv is not a file"),
])
def test_bad_arguments_are_named(args, message, capsys):
    assert paired_results.main(args) == 2
    assert re.search(re.escape(message), capsys.readouterr().err)


def test_a_method_missing_from_a_file_is_named(tmp_path, capsys):
    run = write_run(tmp_path / "r.csv", {(5, 0): "success"})
    assert paired_results.main([f"a={run}", f"b={run}", "--method", "s_dovs"]) == 2
    assert "no episode of method 's_dovs' (it holds dqn_dovs)" in capsys.readouterr().err
