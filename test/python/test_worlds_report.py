"""docs/benchmark_worlds.md generator on hand-built run folders: the three protocols' tables, the paired wins / losses
and exact sign-test p-values (on success, and on robot-at-fault contacts for the oblivious stress test), the oracle's
target, the cost figures, the plot, runs the tool stopped, a protocol not run, the discussion's marked place, the run
record, and the errors for missing or mismatched run folders."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from dqn_dovs_py import worlds_report as wr
from dqn_dovs_py.report import COMFORT_COLUMNS, COST_COLUMNS, FAULT_COLUMNS, RESULTS_COLUMNS

EPISODES = 10
METHODS = ("dqn_dovs", "s_dovs", "orca_diffdrive", "dwa", "oracle")
MIXES = {p.name: p.mix for p in wr.PROTOCOLS}


def outcome_of(protocol: str, family: str, n: int, method: str, k: int) -> tuple[str, bool]:
    """(outcome, robot at fault) of one episode. In every run: the oracle solves all but, in the headline doorway at
    N = 8, episodes 1-2 (0.80, short of the target); dqn_dovs solves episodes 1-8; s_dovs 1-5 in the corridor and 1-8
    elsewhere; orca and dwa the odd episodes. Failures are collisions; a baseline's are at fault, dqn_dovs's are hits
    at rest in the oblivious protocol and at fault otherwise."""
    if method == "oracle":
        ok = not (protocol == "headline" and family == "doorway" and n == 8 and k <= 2)
    elif method == "dqn_dovs":
        ok = k <= 8
    elif method == "s_dovs":
        ok = k <= (5 if family == "corridor" else 8)
    else:
        ok = k % 2 == 1
    if ok:
        return "success", False
    return "collision", not (method == "dqn_dovs" and protocol == "oblivious")


def write_run(root: Path, protocol: str, family: str, n: int) -> Path:
    folder = root / protocol / f"{family}_n{n}"
    folder.mkdir(parents=True)
    with open(folder / "results.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(RESULTS_COLUMNS + FAULT_COLUMNS + COMFORT_COLUMNS + COST_COLUMNS)
        for method in METHODS:
            for k in range(1, EPISODES + 1):
                outcome, fault = outcome_of(protocol, family, n, method, k)
                ok = outcome == "success"
                w.writerow([method, n, k, f"{family}/57101/{n}/{k}", outcome, 12.0 if ok else 3.0, 5.0, 0.3, 0, 60,
                            0, "" if ok else "moving" if fault else "rest", "" if ok else 0.4 if fault else 0.0,
                            "note", "" if ok else "person_on_robot", "" if ok else int(fault), 1.0, 4.0,
                            0.5, "" if protocol == "oblivious" else 2.0, 2.5 if ok else "", 0.75])
    run = {"command": f"dqn_dovs_eval --world {family} --obstacles {n} --out {folder}", "scenarios": "generated",
           "seed": 57101, "obstacles_min": n, "obstacles_max": n, "episodes": EPISODES, "dynamic_fraction": 0.85,
           "world": family, "sensor": "sim", "people_model": "social_force", "people_see_robot": False,
           "people_mix": MIXES[protocol], "perfect_info": False, "step_s": 0.2, "max_steps": 500, "wall_s": 1.25,
           "threads": 2, "methods": list(METHODS), "reference": "dqn_dovs", "goal_tolerance_m": 0.15,
           "people_predictor": "models/people_predictor_tracks.dqnp"}
    (folder / "run.json").write_text(json.dumps(run))
    return folder


@pytest.fixture
def runs(tmp_path: Path) -> Path:
    """The headline and oblivious protocols; attentive not run."""
    root = tmp_path / "results" / "benchmark_worlds"
    for protocol in ("headline", "oblivious"):
        for family in wr.FAMILIES:
            for n in wr.COUNTS:
                write_run(root, protocol, family, n)
    return root


def make_report(runs: Path, tmp_path: Path, discussion: Path | None = None) -> str:
    out = tmp_path / "docs" / "benchmark_worlds.md"  # the repository's layout: the report in docs/, data in results/
    out.parent.mkdir(exist_ok=True)
    wr.write_report(str(runs), str(out), str(discussion or tmp_path / "no_discussion.md"))
    return out.read_text()


def test_paired_counts_on_success_and_on_fault(runs: Path):
    loaded = wr.load_runs(str(runs))
    headline, oblivious = wr.PROTOCOLS[0], wr.PROTOCOLS[1]
    corridor = wr.pooled(loaded, "headline", "corridor")
    p = wr.paired(corridor, "dqn_dovs", "s_dovs", wr.good_of(headline))
    assert (p.episodes, p.wins, p.losses) == (30, 9, 0)  # episodes 6-8 at each N
    assert p.p_value == pytest.approx(2 / 2 ** 9)
    even = wr.paired(corridor, "dqn_dovs", "dwa", wr.good_of(headline))
    assert (even.wins, even.losses) == (12, 3)  # 2, 4, 6, 8 against 9 at each N
    # The stress test counts episodes without a robot-at-fault contact: dqn_dovs's failures there are hits at rest.
    stress = wr.paired(wr.pooled(loaded, "oblivious", "crowd"), "dqn_dovs", "s_dovs", wr.good_of(oblivious))
    assert (stress.wins, stress.losses) == (6, 0)
    assert wr.fault_rate(wr.of(wr.pooled(loaded, "oblivious"), "dqn_dovs")) == 0.0
    assert wr.fault_rate(wr.of(wr.pooled(loaded, "headline"), "dqn_dovs")) == pytest.approx(0.2)


def test_protocol_tables_and_oracle_target(runs: Path, tmp_path: Path):
    text = make_report(runs, tmp_path)
    assert "## Headline mix (the main table)" in text and "## Oblivious stress test" in text
    assert "## All attentive" in text and "not run." in text  # no attentive folder
    header = "| family | DQN-DOVS | S-DOVS | ORCA (diff-drive) | DWA | oracle |"
    assert text.count(header) == 2
    assert "| corridor | 0.80 / 0.20 | 0.50 / 0.50 | 0.50 / 0.50 | 0.50 / 0.50 | 1.00 / 0.00 |" in text
    assert "| corridor | +9 / -0, p = 0.0039 * | +12 / -3, p = 0.035 * | +12 / -3, p = 0.035 * |" in text
    # Pooled over the families, each pairs within itself: the corridor's 9 and every family's 12 / 3.
    assert "| **all** | +9 / -0, p = 0.0039 * | +60 / -15, p = " in text
    assert "short of 0.95 at N = 8: doorway (0.80)" in text
    assert "at least 0.95 of every family at N = 8" in text  # the oblivious protocol's oracle solves all
    assert "| doorway | 1.00 | 0.80 | 1.00 |" in text.split("## Headline mix")[1].split("## Oblivious")[0]
    # Cost figures: means per episode (delay not recorded in the oblivious protocol).
    assert "| DQN-DOVS | 1.00 | 4.00 | 0.50 | 2.0 | 2.50 | 0.75 |" in text
    assert "| DQN-DOVS | 1.00 | 4.00 | 0.50 | - | 2.50 | 0.75 |" in text
    assert (tmp_path / "results" / "benchmark_worlds" / wr.PLOT).stat().st_size > 10_000
    assert f"](../results/benchmark_worlds/{wr.PLOT})" in text


def test_a_stopped_run_is_shown_with_its_error(runs: Path, tmp_path: Path):
    folder = runs / "headline" / "junction_n12"
    for f in folder.iterdir():
        f.unlink()
    (folder / wr.FAILED).write_text("world generator 'junction' (seed 57101): no free place for person 11\n")
    text = make_report(runs, tmp_path)
    assert "| junction | 12 | not run: world generator 'junction' (seed 57101): no free place for person 11 |" in text


def test_missing_or_mismatched_runs_are_named(runs: Path, tmp_path: Path):
    for f in (runs / "oblivious" / "crowd_n4").iterdir():
        f.unlink()
    (runs / "oblivious" / "crowd_n4").rmdir()
    data = json.loads((runs / "headline" / "clutter_n8" / "run.json").read_text())
    data["people_mix"] = "oblivious=1"
    (runs / "headline" / "clutter_n8" / "run.json").write_text(json.dumps(data))
    with pytest.raises(ValueError) as e:
        wr.load_runs(str(runs))
    assert "oblivious/crowd_n4: missing run folder" in str(e.value)
    assert "people_mix 'oblivious=1' (expected 'attentive=0.7,impassive=0.2,oblivious=0.1')" in str(e.value)
    with pytest.raises(ValueError, match="no such folder"):
        wr.load_runs(str(tmp_path / "nowhere"))
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="none of the protocol folders"):
        wr.load_runs(str(tmp_path / "empty"))


def test_discussion_and_run_record(runs: Path, tmp_path: Path):
    discussion = tmp_path / "discussion.md"
    discussion.write_text("Hand-written: the planners tie among people who give way.\n")
    model = tmp_path / "model.dqnw"
    model.write_bytes(b"weights")
    assert wr.main(["--runs", str(runs), "--out", str(tmp_path / "out.md"), "--discussion", str(discussion),
                    "--commit", "abc1234", "--model", str(model), "--total-wall", "1234.5", "--episodes", "10",
                    "--seed", "57101"]) == 0
    text = (tmp_path / "out.md").read_text()
    assert "Hand-written: the planners tie among people who give way." in text
    assert wr.DISCUSSION_BEGIN.format(path=str(discussion)) in text
    assert "commit `abc1234`" in text and "1234 s" in text
    assert "seed 57101" in text and "10 episodes per family, N and method" in text
    info = json.loads((runs / wr.RUN_INFO).read_text())
    assert info["episodes"] == 10 and info["seed"] == 57101
    with pytest.raises(SystemExit):
        wr.main(["--runs", str(runs), "--commit", "abc"])
