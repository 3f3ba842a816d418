"""Every file in models/ names where it came from (dqn_dovs_py.provenance: config, seed, source commit, init from),
an .onnx names the .dqnw it was made from, and the trainer writes the keys itself. The files are found by glob, so a
file added to models/ is held to it too.

The trainer's test needs dqn_dovs_py._core (skipped without it unless DQN_DOVS_REQUIRE_CORE=1); the rewriting test
reads the result with the C++ tool dqn_dovs_qnet_eval from DQN_DOVS_BIN_DIR.
"""

import hashlib
import os
import re
import shutil
import struct
import subprocess
import zlib
from pathlib import Path

import pytest
import yaml
from built_tools import built_tool
from dqn_dovs_py import provenance
from dqn_dovs_py.export import load_weights, read_onnx_metadata

REPO = Path(__file__).resolve().parents[2]
MODELS = REPO / "models"
MODEL_SUFFIXES = (".dqnw", ".onnx", ".dqnp")
MODEL_FILES = sorted(p for p in MODELS.iterdir() if p.suffix in MODEL_SUFFIXES)


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _git(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(["git", "-C", str(REPO), *args], capture_output=True, text=True)


def test_models_holds_only_files_with_a_provenance_rule():
    assert {p.suffix for p in MODEL_FILES} >= {".dqnw", ".onnx", ".dqnp"}
    for path in MODELS.iterdir():
        if path.is_dir() or path.suffix in MODEL_SUFFIXES or path.name == "README.md":
            continue
        # The .json beside a people predictor holds its metadata; nothing else may sit here unchecked.
        assert path.suffix == ".json" and path.with_suffix(".dqnp").is_file(), \
            f"{path}: no provenance rule for this file (a model is .dqnw, .onnx or .dqnp)"


@pytest.mark.parametrize("path", MODEL_FILES, ids=lambda p: p.name)
def test_every_model_file_names_its_provenance(path: Path):
    found = provenance.read(path)
    assert provenance.problems(found) == [], f"{path}: {found}"
    assert set(found) == set(provenance.KEYS)
    assert re.fullmatch(r"-?\d+", found["seed"]), f"{path}: seed {found['seed']!r}"
    commit = found["source commit"]
    assert re.fullmatch(r"[0-9a-f]{40}", commit), f"{path}: a shipped file is trained from a commit, not {commit!r}"
    if _git("rev-parse", "--is-shallow-repository").stdout.strip() == "false":
        assert _git("cat-file", "-e", f"{commit}^{{commit}}").returncode == 0, f"{path}: no commit {commit}"
    named = provenance.init_from_file(found)
    assert named is not None or found["init from"] == "none", f"{path}: init from {found['init from']!r}"


@pytest.mark.parametrize("path", [p for p in MODEL_FILES if p.suffix != ".onnx"], ids=lambda p: p.name)
def test_init_from_names_a_file_in_models_by_its_sha256(path: Path):
    named = provenance.init_from_file(provenance.read(path))
    if named is None:
        return
    source, sha = named
    assert source.startswith("models/"), f"{path}: a shipped file starts from a shipped file, not {source}"
    assert (REPO / source).is_file(), f"{path}: init from {source}, which is not there"
    assert _sha256(REPO / source) == sha, f"{path}: init from {source} names another sha256 than the file's"
    assert REPO / source != path


@pytest.mark.parametrize("path", [p for p in MODEL_FILES if p.suffix == ".onnx"], ids=lambda p: p.name)
def test_an_onnx_names_the_sha256_of_its_dqnw(path: Path):
    weights = path.with_suffix(".dqnw")
    assert weights.is_file(), f"{path}: no {weights.name} beside it"
    props = read_onnx_metadata(path)
    assert props["dqn_dovs.weights_file"] == weights.name
    assert props["dqn_dovs.weights_sha256"] == _sha256(weights)
    assert props["dqn_dovs.metadata"] == load_weights(weights).metadata


def test_the_source_commit_is_this_trees_head():
    commit = provenance.source_commit()
    head = _git("rev-parse", "HEAD").stdout.strip()
    dirty = bool(_git("status", "--porcelain", "--untracked-files=no").stdout.strip())
    assert commit == head + ("+uncommitted" if dirty else "")
    assert provenance.source_commit(REPO.parent / "no_such_repository") == "unknown"


def test_set_rewrites_only_the_metadata(tmp_path):
    original = MODELS / "dqn_dovs.dqnw"
    copy = tmp_path / "net.dqnw"
    shutil.copy(original, copy)
    before = copy.read_bytes()
    old_metadata = load_weights(copy).metadata
    init = tmp_path / "start.dqnw"
    shutil.copy(MODELS / "curriculum.dqnw", init)
    commit = _git("rev-parse", "HEAD").stdout.strip()
    assert provenance.main(["set", str(copy), "--config", "config/finetune_crowd.yaml", "--seed", "7",
                            "--source-commit", commit, "--init-from", str(init), "--note", "rewritten"]) == 0
    after = copy.read_bytes()
    keep = len(before) - 8 - len(old_metadata.encode())  # every field before the metadata
    assert after[:keep] == before[:keep] and after != before
    assert struct.unpack("<I", after[-4:])[0] == zlib.crc32(after[:-4])
    text = load_weights(copy).metadata
    assert provenance.read(copy) == {"config": "config/finetune_crowd.yaml", "seed": "7", "source commit": commit,
                                     "init from": f"{init.resolve()} sha256 {_sha256(init)}"}
    assert "provenance note: rewritten" in text
    # The lines that were not provenance stay, in their order; the old layout's revision line is gone.
    others = [line for line in old_metadata.splitlines()
              if line.partition(": ")[0] not in (*provenance.KEYS, provenance.NOTE_KEY)]
    assert len(others) == 5  # training command, exported, checkpoint, note, state parameters
    assert [line for line in text.splitlines() if line in others] == others
    assert text.splitlines()[1].startswith("exported: ")
    assert text.splitlines()[2] == "config: config/finetune_crowd.yaml"
    # The planner's own reader takes it and shows the new metadata.
    info = subprocess.run([str(built_tool("dqn_dovs_qnet_eval")), "--info", str(copy)], capture_output=True, text=True)
    assert info.returncode == 0, info.stderr
    assert f"source commit: {commit}" in info.stdout


def test_set_refuses_what_it_cannot_establish(tmp_path, capsys):
    copy = tmp_path / "net.dqnw"
    shutil.copy(MODELS / "dqn_dovs.dqnw", copy)
    before = copy.read_bytes()
    assert provenance.main(["set", str(copy), "--config", "c.yaml", "--seed", "1", "--source-commit", "unknown",
                            "--init-from", "none"]) == 2
    err = capsys.readouterr().err
    assert f"{copy}: refusing to write an incomplete provenance: 'source commit' is 'unknown'" in err
    assert copy.read_bytes() == before
    assert provenance.main(["set", str(copy), "--config", "c.yaml", "--seed", "1", "--source-commit", "HEAD",
                            "--init-from", str(tmp_path / "missing.dqnw")]) == 2
    assert f"init from '{tmp_path / 'missing.dqnw'}': cannot read it" in capsys.readouterr().err
    onnx = tmp_path / "net.onnx"
    shutil.copy(MODELS / "dqn_dovs.onnx", onnx)
    assert provenance.main(["set", str(onnx), "--config", "c.yaml", "--seed", "1", "--source-commit", "HEAD",
                            "--init-from", "none"]) == 2
    assert "--onnx-from" in capsys.readouterr().err
    # check names a file without the keys.
    bare = tmp_path / "bare.dqnw"
    data = provenance.rewrite_weight_metadata(before, "training command: test", str(bare))
    bare.write_bytes(data)
    assert provenance.main(["check", str(bare), str(copy)]) == 1
    err = capsys.readouterr().err
    assert f"{bare}: 'config' missing" in err and str(copy) + ":" not in err


def test_the_trainer_writes_its_provenance(tmp_path):
    try:
        from dqn_dovs_py import _core  # noqa: F401, PLC0415
    except ImportError as error:
        if os.environ.get("DQN_DOVS_REQUIRE_CORE") == "1":
            pytest.fail(f"dqn_dovs_py._core cannot be imported ({error}) [DQN_DOVS_REQUIRE_CORE=1]")
        pytest.skip(f"dqn_dovs_py._core cannot be imported ({error})")
    from dqn_dovs_py.export import main as export_main  # noqa: PLC0415
    from dqn_dovs_py.train import main as train_main  # noqa: PLC0415

    raw = yaml.safe_load((REPO / "config" / "curriculum.yaml").read_text())
    raw["num_envs"] = 2
    raw["replay"].update(capacity=2000, batch_size=16, learning_starts=32, transitions_per_update=16)
    raw["evaluation"].update(every_episodes=0, episodes=2, num_envs=2, keep_snapshots=False)
    raw["checkpoint"].update(every_episodes=0, save_replay=False)
    raw["log"]["plot_every_episodes"] = 0
    raw["curriculum"]["stages"] = [dict(raw["curriculum"]["stages"][-1], episodes=2)]
    config = tmp_path / "tiny.yaml"
    config.write_text(yaml.safe_dump(raw))
    start = MODELS / "dqn_dovs.dqnw"
    out = tmp_path / "run"
    assert train_main(["--config", str(config), "--out", str(out), "--seed", "5", "--init-from", str(start),
                       "--device", "cpu", "--no-progress"]) == 0
    expected = {"config": str(config.resolve()), "seed": "5", "source commit": provenance.source_commit(),
                "init from": f"models/dqn_dovs.dqnw sha256 {_sha256(start)}"}
    for name in ("model.dqnw", "best.dqnw", "model.onnx"):
        assert provenance.read(out / name) == expected, name
    # The checkpoint carries it, so an export of the checkpoint writes it too; the state parameters likewise (the
    # environments' dovs/* and robot/*: the defaults here).
    assert export_main([str(out / "checkpoint.pt"), str(tmp_path / "again.dqnw"), "--no-onnx"]) == 0
    assert provenance.read(tmp_path / "again.dqnw") == expected
    line = f"state parameters: {_core.state_parameters()}"
    for name in ("model.dqnw", "best.dqnw"):
        assert line in load_weights(out / name).metadata.splitlines(), name
    assert line in load_weights(tmp_path / "again.dqnw").metadata.splitlines()


def test_the_shipped_network_names_the_robots_state_parameters(tmp_path):
    """The deployed network's `state parameters:` line is what config/dovs.yaml and config/robot.yaml give
    (planner_node refuses it otherwise), and `provenance state` writes such a line, replacing the old one only."""
    try:
        from dqn_dovs_py import _core  # noqa: PLC0415
    except ImportError as error:
        if os.environ.get("DQN_DOVS_REQUIRE_CORE") == "1":
            pytest.fail(f"dqn_dovs_py._core cannot be imported ({error}) [DQN_DOVS_REQUIRE_CORE=1]")
        pytest.skip(f"dqn_dovs_py._core cannot be imported ({error})")
    dovs = yaml.safe_load((REPO / "config" / "dovs.yaml").read_text())["dovs"]
    robot = yaml.safe_load((REPO / "config" / "robot.yaml").read_text())["robot"]
    line = [x for x in load_weights(MODELS / "dqn_dovs.dqnw").metadata.splitlines()
            if x.startswith("state parameters: ")]
    assert len(line) == 1
    words = dict(w.split("=") for w in line[0].split(": ", 1)[1].split())
    for name, value in dovs.items():
        assert float(words[f"dovs/{name}"]) == float(value), name
    for name in ("a_v", "a_w", "dt", "radius"):
        assert float(words[f"robot/{name}"]) == float(robot[name]), name
    copy = tmp_path / "net.dqnw"
    shutil.copy(MODELS / "dqn_dovs.dqnw", copy)
    assert provenance.main(["state", str(copy), "--dovs", "safety_factor=1.5"]) == 0
    text = load_weights(copy).metadata.splitlines()
    assert sum(x.startswith("state parameters: ") for x in text) == 1
    assert "dovs/safety_factor=1.5" in [x for x in text if x.startswith("state parameters: ")][0]
    assert [x for x in text if not x.startswith("state parameters: ")] == \
        [x for x in load_weights(MODELS / "dqn_dovs.dqnw").metadata.splitlines() if not x.startswith("state param")]
    assert provenance.main(["state", str(tmp_path / "x.dqnp")]) == 2
