"""The learned people predictor: features and export against the C++ inference, a short training run on paths that
dqn_dovs_eval wrote, the oracle running on its file, and bad inputs named."""

import json
import subprocess

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from built_tools import built_tool  # noqa: E402
from dqn_dovs_py import people_predictor as pp  # noqa: E402
from dqn_dovs_py import provenance  # noqa: E402


def _random_network(path, hidden=(16, 12), seed=3):
    torch.manual_seed(seed)
    layers, width = [], pp.input_size()
    for h in hidden:
        layers += [torch.nn.Linear(width, h), torch.nn.ReLU()]
        width = h
    layers.append(torch.nn.Linear(width, 2 * pp.FUTURE))
    net = torch.nn.Sequential(*layers)
    rng = np.random.default_rng(seed)
    mean = rng.normal(0.0, 0.3, pp.input_size()).astype(np.float32)
    scale = rng.uniform(0.5, 2.0, pp.input_size()).astype(np.float32)
    pp.export(path, net, mean, scale, 0.2)
    return net, mean, scale


def _scenes(rng):
    """Walking people (straight, turning, standing, fewer than NEIGHBOURS or more) in an 8 x 8 m room."""
    scenes = []
    for people in (1, 3, 9):
        start = rng.uniform(-3.0, 3.0, (people, 2))
        velocity = rng.uniform(-1.2, 1.2, (people, 2))
        velocity[0] *= people > 1  # the first one stands (from the second scene on)
        bend = rng.normal(0.0, 0.05, (people, pp.HISTORY + 1, 2))
        steps = np.arange(pp.HISTORY + 1)[None, :, None] * 0.2
        scenes.append(start[:, None, :] + velocity[:, None, :] * steps + np.cumsum(bend, axis=1) * (people > 1))
    return scenes


# The room, a slanted wall and a short one inside it (the third scene has no walls at all).
WALLS = [np.concatenate([pp.square_room(4.0), [[-3.0, 2.5, 1.0, 3.5], [0.5, -1.0, 0.5, -2.0]]]),
         pp.square_room(4.0), np.zeros((0, 4))]


def _cpp_predictions(tmp_path, path, scenes):
    lines = [" ".join([str(len(s)), str(len(w))] + [f"{v:.9f}" for v in np.concatenate([w.ravel(), s.ravel()])])
             for s, w in zip(scenes, WALLS)]
    (tmp_path / "scenes.txt").write_text("\n".join(lines) + "\n")
    result = subprocess.run([str(built_tool("dqn_dovs_people_predict")), str(path), str(tmp_path / "scenes.txt"),
                             str(tmp_path / "out.txt")], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    return np.array([[float(v) for v in line.split()] for line in (tmp_path / "out.txt").read_text().splitlines()])


def test_the_cpp_inference_predicts_what_the_exported_network_does(tmp_path):
    path = tmp_path / "net.dqnp"
    net, mean, scale = _random_network(path)
    model = pp.load(path)
    assert model["version"] == 2
    scenes = _scenes(np.random.default_rng(5))
    cpp = _cpp_predictions(tmp_path, path, scenes)
    expected = np.concatenate([pp.predict(model, s, w).reshape(len(s), -1) for s, w in zip(scenes, WALLS)])
    assert cpp.shape == expected.shape == (13, 2 * pp.FUTURE)
    np.testing.assert_allclose(cpp, expected, atol=2e-5)
    # A version 1 file (the walls along the room's axes) is still read the same way on both sides.
    v1 = tmp_path / "v1.dqnp"
    v1.write_bytes(b"DQNDPPv1" + path.read_bytes()[8:])
    expected_v1 = np.concatenate([pp.predict(pp.load(v1), s, w).reshape(len(s), -1) for s, w in zip(scenes, WALLS)])
    np.testing.assert_allclose(_cpp_predictions(tmp_path, v1, scenes), expected_v1, atol=2e-5)
    assert np.abs(expected_v1 - expected).max() > 1e-3, "the versions read the walls differently"
    # The numpy reference is the network itself: PyTorch on the same inputs gives the same correction.
    x, velocity, along = pp.features(scenes[2], WALLS[2], 0.2)
    with torch.no_grad():
        correction = net(torch.tensor((x - mean) / scale, dtype=torch.float32)).numpy()
    cv = np.stack([pp._to_frame(along[i], np.outer(np.arange(1, pp.FUTURE + 1) * 0.2, velocity[i])).ravel()
                   for i in range(len(x))])
    frame = np.stack([pp._to_frame(along[i], expected[4 + i].reshape(-1, 2) - scenes[2][i, -1]).ravel()
                      for i in range(len(x))])
    np.testing.assert_allclose(frame, cv + correction, atol=1e-4)


def test_a_zero_network_is_constant_velocity(tmp_path):
    path = tmp_path / "zero.dqnp"
    net, _, _ = _random_network(path)
    with torch.no_grad():
        for p in net.parameters():
            p.zero_()
    pp.export(path, net, np.zeros(pp.input_size()), np.ones(pp.input_size()), 0.2)
    scene = _scenes(np.random.default_rng(8))[1]
    predicted = pp.predict(pp.load(path), scene, pp.square_room(4.0))
    velocity = (scene[:, -1] - scene[:, -2]) / 0.2
    for k in range(pp.FUTURE):
        np.testing.assert_allclose(predicted[:, k], scene[:, -1] + velocity * 0.2 * (k + 1), atol=1e-9)


def _paths(tmp_path, seed, name):
    out = tmp_path / name
    result = subprocess.run([str(built_tool("dqn_dovs_eval")), "--methods", "s_dovs", "--generate", str(seed),
                             "--obstacles", "5", "--episodes", "3", "--threads", "1", "--world", "crowd",
                             "--trajectories", "3", "--no-report", "--out", str(out)], capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr
    return out


def test_a_short_training_run_exports_a_file_the_oracle_predicts_with(tmp_path):
    train_dir, valid_dir = _paths(tmp_path, 41, "train"), _paths(tmp_path, 42, "valid")
    out = tmp_path / "pp.dqnp"
    assert pp.main(["--train", str(train_dir), "--valid", str(valid_dir), "--out", str(out), "--epochs", "2",
                    "--hidden", "16"]) == 0
    summary = json.loads(out.with_suffix(".json").read_text())
    assert summary["train_samples"] > 100 and summary["valid_samples"] > 100
    for key in ("ade", "at_0.6s", "at_1s", "at_2s"):
        assert 0.0 < summary["constant_velocity"][key] < 5.0 and 0.0 < summary["learned"][key] < 5.0
    # Per family (the folder's name up to its first '_'): here one, holding every validation sample.
    assert list(summary["per_family"]) == ["valid"]
    assert summary["per_family"]["valid"]["samples"] == summary["valid_samples"]
    assert summary["per_family"]["valid"]["learned"]["at_2s"] == pytest.approx(summary["learned"]["at_2s"], rel=1e-4)
    # Its provenance, kept in the .json (the .dqnp has no metadata): the options, the seed, this tree's commit.
    found = provenance.read(out)
    assert provenance.problems(found) == [] and found["seed"] == "0" and found["init from"] == "none"
    assert found["config"].startswith("people_predictor --inputs truth --epochs 2 --hidden 16 --step 0.2 --train ")
    assert f"--valid {valid_dir.resolve()}" in found["config"]
    assert found["source commit"].split("+")[0] == subprocess.run(
        ["git", "-C", str(provenance.REPO_ROOT), "rev-parse", "HEAD"], capture_output=True, text=True).stdout.strip()
    eval_cmd = [str(built_tool("dqn_dovs_eval")), "--methods", "oracle", "--generate", "43", "--obstacles", "5",
                "--episodes", "2", "--threads", "1", "--world", "crowd", "--no-report"]
    ran = subprocess.run(eval_cmd + ["--oracle", f"true_future_periods=0,learned_prediction={out}",
                                     "--out", str(tmp_path / "eval")], capture_output=True, text=True)
    assert ran.returncode == 0, ran.stdout + ran.stderr
    assert len((tmp_path / "eval" / "results.csv").read_text().splitlines()) == 3
    # The planners take it as arcs (--predict-people), with the tracker and with perfect information.
    for flags in ([], ["--perfect-info"]):
        planners = subprocess.run([str(built_tool("dqn_dovs_eval")), "--methods", "s_dovs,dqn_dovs", "--generate", "43",
                                   "--obstacles", "5", "--episodes", "2", "--threads", "1", "--world", "crowd",
                                   "--no-report", "--predict-people", str(out), "--out",
                                   str(tmp_path / f"planners{len(flags)}")] + flags, capture_output=True, text=True)
        assert planners.returncode == 0, planners.stdout + planners.stderr
    # A corrupt file and a prediction mixed with another are refused, naming the file or the parameter.
    broken = tmp_path / "broken.dqnp"
    broken.write_bytes(out.read_bytes()[:-5])
    refused = subprocess.run(eval_cmd + ["--oracle", f"true_future_periods=0,learned_prediction={broken}",
                                         "--out", str(tmp_path / "bad")], capture_output=True, text=True)
    assert refused.returncode != 0
    assert "broken.dqnp" in refused.stdout + refused.stderr and "truncated" in refused.stdout + refused.stderr
    refused_planners = subprocess.run([str(built_tool("dqn_dovs_eval")), "--methods", "s_dovs", "--generate", "43",
                                       "--obstacles", "5", "--episodes", "1", "--world", "crowd", "--no-report",
                                       "--predict-people", str(broken), "--out", str(tmp_path / "bad2")],
                                      capture_output=True, text=True)
    assert refused_planners.returncode != 0
    assert "broken.dqnp" in refused_planners.stdout + refused_planners.stderr
    mixed = subprocess.run(eval_cmd + ["--oracle", f"learned_prediction={out}", "--out", str(tmp_path / "mixed")],
                           capture_output=True, text=True)
    assert mixed.returncode != 0 and "true_future_periods = 0" in mixed.stdout + mixed.stderr


def test_training_data_that_is_not_paths_is_named(tmp_path):
    (tmp_path / "paths.json").write_text("{}")
    with pytest.raises(pp.PredictorDataError, match="paths.json"):
        pp.samples_from_paths(tmp_path / "paths.json", 0.2)
    assert pp.main(["--train", str(tmp_path), "--valid", str(tmp_path), "--out", str(tmp_path / "x.dqnp")]) == 2


def test_track_histories_are_kept_as_the_planners_keep_them():
    # Track 5 walks east at 1 m/s (0.2 m per decision; the tracker says 0.5 m/s) and is missed at decision 3; track 9
    # stands (static).
    decisions = []
    for k in range(8):
        rows = [[9, 2.0, 2.0, 0.0, 0.0, 1]]
        if k != 3:
            rows.append([5, 0.2 * k, 1.0, 0.5, 0.0, 0])
        decisions.append(rows)
    out = dict(pp.track_histories(decisions, 0.2))
    assert out[3].shape == (0, pp.HISTORY + 1, 2)
    # Seen for the first time (decision 0), and again after the miss (decision 4): walked back at its reported velocity.
    for k in (0, 4):
        np.testing.assert_allclose(out[k][0, :, 0], 0.2 * k - 0.1 * np.arange(pp.HISTORY, -1, -1), atol=1e-12)
    # Decision 6: its own positions at 4, 5, 6, the older ones walked back from where it is now.
    np.testing.assert_allclose(out[6][0, -3:, 0], [0.8, 1.0, 1.2], atol=1e-12)
    np.testing.assert_allclose(out[6][0, :3, 0], [0.7, 0.8, 0.9], atol=1e-12)
    np.testing.assert_allclose(out[7][0, :, 1], 1.0)


def test_paths_without_tracks_are_named(tmp_path):
    (tmp_path / "paths.json").write_text(json.dumps({"episodes": [{"obstacle_paths": [], "room_half_size_m": 4}]}))
    with pytest.raises(pp.PredictorDataError, match="no tracks"):
        pp.samples_from_tracks(tmp_path / "paths.json", 0.2)
