"""Seeds x configurations on Ray: each trial trains, exports and is evaluated on held-out generated episodes.

    python -m dqn_dovs_py.sweep --configs config/curriculum.yaml my.yaml --seeds 1 2 3 --out runs/sweep_NAME

Each (configuration, seed) is one Ray task. It runs the trainer as a subprocess (its own process, PyTorch threads and
log: `python -m dqn_dovs_py.train --config C --seed S --out TRIAL/run --no-progress`, output in TRIAL/train.log),
then evaluates the trained network (TRIAL/run/model.dqnw) as `dqn_dovs` with dqn_dovs_eval on generated episodes
(`--generate SEED --obstacles A-B --episodes K`: the evaluation's own scenario generator, never the training
environments' episodes) into TRIAL/eval/results.csv, TRIAL = OUT/trials/CONFIG/seedS. The baseline methods (default
`s_dovs`, which needs no network) and, when asked, a reference weight file (`--reference models/dqn_dovs.dqnw`) are
evaluated once on the same episodes (OUT/baselines/METHOD/, OUT/reference/).

With --eval-worlds FAMILY,... every side is evaluated instead in each of those world families at each count of
--eval-obstacles (a list such as 4,8,12, the default there, or A-B), one dqn_dovs_eval run per family and count
(`--world FAMILY --obstacles N`, plus --eval-people-mix, e.g. `headline`) into EVAL/FAMILY_nN/results.csv, EVAL
being TRIAL/eval, OUT/baselines/METHOD or OUT/reference; e.g. `--eval-worlds crowd,corridor,doorway,clutter,junction
--eval-people-mix headline --eval-obstacles 4,8,12 --eval-episodes 34`: 510 episodes per side. A rate is then the
mean over the family and count runs, and the tables add the robot-at-fault rate (results.csv's at_fault) and each
family's success and robot-at-fault rate. --eval-threads sets each evaluation's --threads (default:
--cpus-per-trial).

Without --address the sweep starts Ray on this machine (`--num-cpus`, default every core); with one it joins that
Ray cluster, whose every node must see the repository (built, with its .venv) and OUT at the same paths, e.g. on
shared storage, and must run Ray from the project's venv (docs/training.md, "Sweeps on Ray").

The sweep prints one line per finished trial and writes OUT/sweep.md, sweep.csv and sweep.json: one table of the
configurations ranked by mean success over their seeds (ties: the lower mean collision rate), with the mean
success, collision and timeout rates, the success of each seed, and paired comparisons of each configuration
against the best one and against each baseline (and the reference). A pair is the same generated episode (scenario,
which names the world family, obstacle count, episode number) played by both sides with the same trial seed
(worlds_report.paired); every seed's pairs are pooled: wins, losses and the exact two-sided sign test
(benchmark_report.sign_test_p). A rate is the mean over the obstacle counts of the
per-count rates (report.summarize, the evaluation summary's mean row). A trial that fails is listed with its error,
the others go on, and the sweep exits 1 at the end; bad input exits 2 before anything runs.
"""

from __future__ import annotations

import argparse
import csv
import datetime
import json
import math
import os
import re
import shlex
import signal
import socket
import subprocess
import sys
import time
from dataclasses import asdict, dataclass, field, replace

from .benchmark_report import Paired, sign_test_p
from .report import Record, read_results, summarize
from .select_model import obstacle_counts

REPO_ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
PYTHON_DIR = os.path.join(REPO_ROOT, "python")
EVAL_TOOL = "dqn_dovs_eval"
DEFAULT_EVAL_TOOL = os.path.join(REPO_ROOT, "install", "lib", "dqn_dovs", EVAL_TOOL)
# The method a trained network is evaluated as.
TRAINED_METHOD = "dqn_dovs"
MODEL_FILES = ("model.dqnw", "best.dqnw")
SWEEP_MD, SWEEP_CSV, SWEEP_JSON = "sweep.md", "sweep.csv", "sweep.json"
TRIALS_DIR, BASELINES_DIR, REFERENCE_DIR = "trials", "baselines", "reference"
TRAIN_LOG, EVAL_LOG, TRIAL_JSON, RUN_DIR, EVAL_DIR = "train.log", "eval.log", "trial.json", "run", "eval"
REFERENCE = "reference"
# dqn_dovs_eval's world families (--world) and the counts of people a worlds evaluation uses by default (those of
# scripts/benchmark_worlds.sh).
WORLD_FAMILIES = ("room", "crowd", "corridor", "doorway", "clutter", "junction")
DEFAULT_OBSTACLES, DEFAULT_WORLD_COUNTS = "3-15", "4,8,12"
SIGNIFICANCE = 0.05
# Seconds the check of a cluster address waits for its port to answer.
CONNECT_TIMEOUT_S = 5.0
# The local Ray instance's object store: the tasks pass paths and small records only.
LOCAL_OBJECT_STORE_BYTES = 256 * 1024 ** 2
# Lines of a failed subprocess's log quoted in its error.
ERROR_LINES = 3


class SweepError(ValueError):
    """Bad input to the sweep; the message names the option or file and the reason."""


# ---- what runs on the Ray workers -------------------------------------------------------------------------------


@dataclass
class Evaluation:
    """One dqn_dovs_eval run of a task: into `out_dir` (results.csv), its output in `log`."""

    label: str  # "" for the one evaluation of the room mode, FAMILY_nN with --eval-worlds
    command: list[str]
    out_dir: str
    log: str


@dataclass
class TrialSpec:
    """One Ray task: a training run and its evaluations (kind "trial"), or the evaluations of a baseline method or
    of the reference weight file (kinds "baseline", "reference"). Commands and paths are absolute."""

    kind: str
    name: str  # the configuration's name, the baseline method or REFERENCE
    seed: int | None  # the training seed; None for a baseline or the reference
    directory: str
    evaluations: list[Evaluation]
    env: dict[str, str]  # added to the worker's environment
    cwd: str
    train_command: list[str] | None = None
    model: str | None = None  # the weight file evaluated (a trial's is written by its training run)

    def label(self) -> str:
        if self.kind == "trial":
            return f"{self.name} seed {self.seed}"
        return f"baseline {self.name}" if self.kind == "baseline" else f"reference {self.model}"


@dataclass
class TrialOutcome:
    """What a task reports back: its status, the files it wrote and its wall times."""

    kind: str
    name: str
    seed: int | None
    directory: str
    ok: bool = False
    error: str = ""
    results: str = ""  # the evaluation's results.csv
    world_results: dict[str, str] = field(default_factory=dict)  # with --eval-worlds: FAMILY_nN -> results.csv
    model: str | None = None
    node: str = ""
    train_s: float = 0.0
    eval_s: float = 0.0
    wall_s: float = 0.0
    train_command: str = ""
    eval_command: str = ""

    def label(self) -> str:
        if self.kind == "trial":
            return f"{self.name} seed {self.seed}"
        return f"baseline {self.name}" if self.kind == "baseline" else f"reference {self.model}"


def _die_with_parent() -> None:
    """Runs in the child before exec: it gets SIGTERM when the worker that started it dies (a cancelled sweep)."""
    try:
        import ctypes  # noqa: PLC0415 - only in the child

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except OSError:
        pass


def _log_tail(path: str, lines: int = ERROR_LINES) -> str:
    """The last non-empty lines of a subprocess's log, after its first line (the command)."""
    try:
        with open(path, errors="replace") as f:
            kept = [line.strip() for line in list(f)[1:] if line.strip()]
    except OSError:
        return ""
    return " | ".join(kept[-lines:]) or "no output"


def _quoted(command: list[str]) -> str:
    return " ".join(shlex.quote(c) for c in command)


def _run_logged(command: list[str], log_path: str, env: dict[str, str], cwd: str) -> int:
    with open(log_path, "w") as log:
        log.write("$ " + _quoted(command) + "\n")
        log.flush()
        return subprocess.run(command, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, env=env,
                              cwd=cwd, preexec_fn=_die_with_parent, check=False).returncode


def run_trial(spec: TrialSpec) -> TrialOutcome:
    """Trains (kind "trial") and evaluates; never raises for a failing subprocess: the outcome carries the error
    (the subprocess's exit status and the last lines of its log). Writes TrialOutcome as DIRECTORY/trial.json."""
    t0 = time.perf_counter()
    out = TrialOutcome(spec.kind, spec.name, spec.seed, spec.directory, model=spec.model, node=socket.gethostname(),
                       train_command=_quoted(spec.train_command) if spec.train_command else "",
                       eval_command="; ".join(_quoted(e.command) for e in spec.evaluations))
    env = dict(os.environ, **spec.env)
    try:
        os.makedirs(spec.directory, exist_ok=True)
        if spec.train_command is not None:
            log = os.path.join(spec.directory, TRAIN_LOG)
            status = _run_logged(spec.train_command, log, env, spec.cwd)
            out.train_s = time.perf_counter() - t0
            if status != 0:
                raise RuntimeError(f"training exited with status {status}: {_log_tail(log)} (log: {log})")
            if not (spec.model and os.path.isfile(spec.model)):
                raise RuntimeError(f"training wrote no {spec.model} (log: {log})")
        t1 = time.perf_counter()
        for e in spec.evaluations:
            os.makedirs(os.path.dirname(e.log), exist_ok=True)
            status = _run_logged(with_state_flags(e.command), e.log, env, spec.cwd)
            out.eval_s = time.perf_counter() - t1
            results = os.path.join(e.out_dir, "results.csv")
            what = f"evaluation {e.label}" if e.label else "evaluation"
            if status != 0:
                raise RuntimeError(f"{what} exited with status {status}: {_log_tail(e.log)} (log: {e.log})")
            if not os.path.isfile(results):
                raise RuntimeError(f"{what} wrote no {results} (log: {e.log})")
            if e.label:
                out.world_results[e.label] = results
            else:
                out.results = results
        out.ok = True
    except (OSError, RuntimeError) as e:
        out.error = str(e)
    out.wall_s = time.perf_counter() - t0
    try:
        with open(os.path.join(spec.directory, TRIAL_JSON), "w") as f:
            json.dump(asdict(out), f, indent=2)
            f.write("\n")
    except OSError:
        pass
    return out


# ---- the sweep's settings -----------------------------------------------------------------------------------------


@dataclass
class ConfigEntry:
    name: str  # the file's stem, made unique
    path: str  # absolute


@dataclass
class Settings:
    """The parsed and checked command line."""

    configs: list[ConfigEntry]
    seeds: list[int]
    out: str
    address: str | None
    num_cpus: int | None
    cpus_per_trial: float
    gpus_per_trial: float
    device: str
    scale: float | None
    init_from: str | None
    model_file: str
    eval_tool: str
    eval_generate: int
    eval_obstacles: str
    eval_episodes: int
    eval_threads: int
    eval_flags: list[str]  # world, sensor, people and odometry flags of dqn_dovs_eval
    baselines: list[str]
    reference: str | None
    python: str
    cwd: str
    # With families: one evaluation per family and count of eval_obstacles ("4,8,12" or "A-B"), --world FAMILY.
    eval_worlds: list[str] = field(default_factory=list)


def eval_counts(s: Settings) -> list[int]:
    """The obstacle (people) counts of the evaluation."""
    return parse_counts(s.eval_obstacles)


def parse_counts(text: str) -> list[int]:
    """`A-B`, `N` or `N1,N2,...` as the sorted counts; [] when malformed (A > B, a repeated count, not numbers)."""
    if re.fullmatch(r"\d+(,\d+)+", text):
        counts = [int(c) for c in text.split(",")]
        return sorted(counts) if len(set(counts)) == len(counts) else []
    return obstacle_counts(text) if re.fullmatch(r"\d+(-\d+)?", text) else []


def find_eval_tool() -> str:
    """dqn_dovs_eval from $DQN_DOVS_BIN_DIR, else the repository's install/lib/dqn_dovs/; SweepError naming where
    it looked when it is not there."""
    bin_dir = os.environ.get("DQN_DOVS_BIN_DIR")
    tool = os.path.join(bin_dir, EVAL_TOOL) if bin_dir else DEFAULT_EVAL_TOOL
    if not (os.path.isfile(tool) and os.access(tool, os.X_OK)):
        where = f"DQN_DOVS_BIN_DIR={bin_dir}" if bin_dir else "the repository's install/lib/dqn_dovs/"
        raise SweepError(f"{EVAL_TOOL} not found or not executable in {where} ({tool}): run 'make build', or "
                         "point DQN_DOVS_BIN_DIR at the folder that holds it")
    return os.path.abspath(tool)


def _config_entries(paths: list[str]) -> list[ConfigEntry]:
    """Each file must exist, appear once and pass the trainer's own check (train.load_config)."""
    from .train import ConfigError, load_config  # noqa: PLC0415 - PyTorch is imported only once the CLI runs

    entries: list[ConfigEntry] = []
    seen: dict[str, str] = {}
    for path in paths:
        if not os.path.isfile(path):
            raise SweepError(f"--configs: {path}: no such file")
        real = os.path.realpath(path)
        if real in seen:
            raise SweepError(f"--configs: {path} is the same file as {seen[real]}; name each configuration once")
        seen[real] = path
        try:
            load_config(path)
        except ConfigError as e:
            raise SweepError(f"--configs: {e}") from None
        stem = os.path.splitext(os.path.basename(path))[0]
        name, i = stem, 2
        while any(e.name == name for e in entries):
            name, i = f"{stem}-{i}", i + 1
        entries.append(ConfigEntry(name, os.path.abspath(path)))
    return entries


def _address_host_port(address: str) -> tuple[str, int] | None:
    """HOST:PORT of a cluster address (`HOST:PORT`, `ray://HOST:PORT`); None for `auto`, which Ray resolves itself."""
    if address == "auto":
        return None
    m = re.fullmatch(r"(?:ray://)?\[?([^\]]+?)\]?:(\d+)", address)
    if not m:
        raise SweepError(f"--address {address}: expected HOST:PORT, ray://HOST:PORT or auto")
    return m.group(1), int(m.group(2))


def check_address(address: str, timeout_s: float = CONNECT_TIMEOUT_S) -> None:
    """SweepError when nothing answers at the cluster address (Ray itself would wait for minutes)."""
    hp = _address_host_port(address)
    if hp is None:
        return
    try:
        with socket.create_connection(hp, timeout=timeout_s):
            pass
    except OSError as e:
        reason = "no answer" if isinstance(e, TimeoutError) else (e.strerror or str(e))
        raise SweepError(f"--address {address}: cannot reach a Ray cluster there ({reason} within {timeout_s:g} s); "
                         "start one with 'ray start --head' or leave --address out to run on this machine") from None


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m dqn_dovs_py.sweep", description=__doc__.splitlines()[0])
    p.add_argument("--configs", nargs="+", required=True, metavar="CONFIG.yaml", help="training configurations")
    p.add_argument("--seeds", nargs="+", required=True, type=int, metavar="SEED", help="training seeds")
    p.add_argument("--out", required=True, help="the sweep's folder, e.g. runs/sweep_NAME (must not hold files)")
    p.add_argument("--address", default=None,
                   help="a Ray cluster to run on (HOST:PORT, ray://HOST:PORT or auto); default: start Ray here")
    p.add_argument("--num-cpus", type=int, default=None, help="CPUs of the local Ray (default: every core)")
    p.add_argument("--cpus-per-trial", type=float, default=1.0,
                   help="CPUs Ray reserves for each trial (default 1); also the evaluation's --threads")
    p.add_argument("--gpus-per-trial", type=float, default=0.0, help="GPUs Ray reserves for each trial (default 0)")
    p.add_argument("--device", default=None, choices=["auto", "cpu", "cuda"],
                   help="the trainer's --device (default: cuda with --gpus-per-trial, else cpu)")
    p.add_argument("--scale", type=float, default=None, help="the trainer's --scale (every stage's episode count)")
    p.add_argument("--init-from", default=None, metavar="MODEL.dqnw", help="the trainer's --init-from")
    p.add_argument("--eval-model", default=MODEL_FILES[0], choices=MODEL_FILES,
                   help="the trained file evaluated (default model.dqnw, the final network)")
    p.add_argument("--eval-generate", type=int, default=9301, help="generator seed of the held-out episodes")
    p.add_argument("--eval-obstacles", default=None,
                   help=f"obstacle counts A-B (default {DEFAULT_OBSTACLES}); with --eval-worlds also a list N1,N2,... "
                        f"(default there {DEFAULT_WORLD_COUNTS})")
    p.add_argument("--eval-episodes", type=int, default=20, help="episodes per obstacle count (default 20)")
    p.add_argument("--eval-threads", type=int, default=None,
                   help="each evaluation's --threads (default: --cpus-per-trial, at least 1)")
    p.add_argument("--eval-world", default=None, help="dqn_dovs_eval --world (room, crowd, corridor, ...)")
    p.add_argument("--eval-worlds", default=None, metavar="FAMILY,...",
                   help="evaluate in each of these world families (e.g. crowd,corridor,doorway,clutter,junction), one "
                        "dqn_dovs_eval run per family and count, instead of one world")
    p.add_argument("--eval-people-mix", default=None, metavar="MIX",
                   help="dqn_dovs_eval --people-mix, e.g. headline (attentive=0.7,impassive=0.2,oblivious=0.1)")
    p.add_argument("--eval-sensor", default=None, help="dqn_dovs_eval --sensor")
    p.add_argument("--eval-people-model", default=None, help="dqn_dovs_eval --people-model")
    p.add_argument("--eval-people-see-robot", action="store_true", help="dqn_dovs_eval --people-see-robot")
    p.add_argument("--eval-odom-noise", default=None, help="dqn_dovs_eval --odom-noise")
    p.add_argument("--eval-perfect-info", action="store_true", help="dqn_dovs_eval --perfect-info")
    p.add_argument("--baseline", nargs="*", default=["s_dovs"], metavar="METHOD",
                   help="methods evaluated once on the same episodes (default s_dovs; --baseline alone: none)")
    p.add_argument("--reference", default=None, metavar="MODEL.dqnw",
                   help="also evaluate this weight file once as dqn_dovs, e.g. models/dqn_dovs.dqnw")
    return p


def settings_from(args: argparse.Namespace) -> Settings:
    """Checks the command line; SweepError names the option and the reason."""
    if len(set(args.seeds)) != len(args.seeds):
        dups = sorted({s for s in args.seeds if args.seeds.count(s) > 1})
        raise SweepError(f"--seeds: {', '.join(map(str, dups))} given more than once")
    if args.num_cpus is not None and args.num_cpus < 1:
        raise SweepError(f"--num-cpus must be >= 1, got {args.num_cpus}")
    if args.num_cpus is not None and args.address is not None:
        raise SweepError("--num-cpus sizes the local Ray; a cluster (--address) has its own CPUs")
    if not args.cpus_per_trial > 0:
        raise SweepError(f"--cpus-per-trial must be > 0, got {args.cpus_per_trial}")
    if args.gpus_per_trial < 0:
        raise SweepError(f"--gpus-per-trial must be >= 0, got {args.gpus_per_trial}")
    if args.num_cpus is not None and args.cpus_per_trial > args.num_cpus:
        raise SweepError(f"--cpus-per-trial {args.cpus_per_trial:g} exceeds --num-cpus {args.num_cpus}: no trial "
                         "could ever start")
    if args.scale is not None and not args.scale > 0:
        raise SweepError(f"--scale must be > 0, got {args.scale}")
    if args.eval_episodes < 1:
        raise SweepError(f"--eval-episodes must be >= 1, got {args.eval_episodes}")
    worlds = [w.strip() for w in args.eval_worlds.split(",")] if args.eval_worlds is not None else []
    if args.eval_worlds is not None:
        if args.eval_world is not None:
            raise SweepError("--eval-world and --eval-worlds: give one (--eval-worlds evaluates in each family)")
        unknown = [w for w in worlds if w not in WORLD_FAMILIES]
        if unknown or not worlds:
            raise SweepError(f"--eval-worlds {args.eval_worlds}: {', '.join(map(repr, unknown)) or 'no family'} is "
                             f"not a world family ({', '.join(WORLD_FAMILIES)})")
        if len(set(worlds)) != len(worlds):
            raise SweepError(f"--eval-worlds {args.eval_worlds}: a family is named more than once")
    obstacles = args.eval_obstacles or (DEFAULT_WORLD_COUNTS if worlds else DEFAULT_OBSTACLES)
    if worlds and not parse_counts(obstacles):
        raise SweepError(f"--eval-obstacles {obstacles}: expected a list N1,N2,... of different counts, A-B with "
                         "A <= B, or one count")
    if not worlds and (not re.fullmatch(r"\d+(-\d+)?", obstacles) or not obstacle_counts(obstacles)):
        hint = " (a list of counts needs --eval-worlds)" if "," in obstacles else ""
        raise SweepError(f"--eval-obstacles {obstacles}: expected A-B with A <= B, or one count{hint}")
    if args.eval_threads is not None and args.eval_threads < 1:
        raise SweepError(f"--eval-threads must be >= 1, got {args.eval_threads}")
    if args.eval_people_mix is not None and args.eval_people_see_robot:
        raise SweepError("--eval-people-mix and --eval-people-see-robot: give one (--eval-people-see-robot is "
                         "--eval-people-mix attentive=1)")
    for option, path in (("--init-from", args.init_from), ("--reference", args.reference)):
        if path is not None and not os.path.isfile(path):
            raise SweepError(f"{option}: {path}: no such file")
    if len(set(args.baseline)) != len(args.baseline):
        raise SweepError(f"--baseline: a method is named more than once ({' '.join(args.baseline)})")
    if any(not re.fullmatch(r"[A-Za-z0-9_]+", m) for m in args.baseline):
        raise SweepError(f"--baseline: expected method names such as s_dovs, got {' '.join(args.baseline)}")
    out = os.path.abspath(args.out)
    if os.path.exists(out) and (not os.path.isdir(out) or os.listdir(out)):
        raise SweepError(f"--out {args.out}: already exists and is not an empty folder; choose a new one")
    if args.address is not None:
        check_address(args.address)
    configs = _config_entries(args.configs)
    eval_flags: list[str] = []
    for flag, value in (("--world", args.eval_world), ("--sensor", args.eval_sensor),
                        ("--people-model", args.eval_people_model), ("--people-mix", args.eval_people_mix),
                        ("--odom-noise", args.eval_odom_noise)):
        if value is not None:
            eval_flags += [flag, value]
    eval_flags += ["--people-see-robot"] * args.eval_people_see_robot + ["--perfect-info"] * args.eval_perfect_info
    device = args.device or ("cuda" if args.gpus_per_trial > 0 else "cpu")
    return Settings(
        configs=configs, seeds=list(args.seeds), out=out, address=args.address, num_cpus=args.num_cpus,
        cpus_per_trial=args.cpus_per_trial, gpus_per_trial=args.gpus_per_trial, device=device, scale=args.scale,
        init_from=os.path.abspath(args.init_from) if args.init_from else None, model_file=args.eval_model,
        eval_tool=find_eval_tool(), eval_generate=args.eval_generate, eval_obstacles=obstacles,
        eval_episodes=args.eval_episodes,
        eval_threads=args.eval_threads if args.eval_threads is not None else max(1, int(args.cpus_per_trial)),
        eval_flags=eval_flags, baselines=list(args.baseline),
        reference=os.path.abspath(args.reference) if args.reference else None, python=sys.executable,
        cwd=os.getcwd(), eval_worlds=worlds)


# ---- the tasks ----------------------------------------------------------------------------------------------------


def _task_env(s: Settings) -> dict[str, str]:
    """The subprocesses' additions: the package on PYTHONPATH, the tool's libraries (install/lib), headless plots."""
    lib = os.path.dirname(os.path.dirname(s.eval_tool))
    old_py, old_ld = os.environ.get("PYTHONPATH"), os.environ.get("LD_LIBRARY_PATH")
    return {"PYTHONPATH": PYTHON_DIR + (os.pathsep + old_py if old_py else ""),
            "LD_LIBRARY_PATH": lib + (os.pathsep + old_ld if old_ld else ""), "MPLBACKEND": "Agg"}


def _eval_command(s: Settings, methods: str, out_dir: str, model: str | None, world: str | None = None,
                  count: int | None = None) -> list[str]:
    """One dqn_dovs_eval run: every count of --eval-obstacles, or with `world` that family at `count` only."""
    command = [s.eval_tool, "--methods", methods]
    if model:
        command += ["--model", model]  # with the state flags of its file when it runs (with_state_flags)
    obstacles = s.eval_obstacles if world is None else str(count)
    return command + ["--generate", str(s.eval_generate), "--obstacles", obstacles, "--episodes",
                      str(s.eval_episodes), "--threads", str(s.eval_threads), "--trajectories", "0", "--no-report",
                      "--out", out_dir + os.sep] + (["--world", world] if world else []) + s.eval_flags


def with_state_flags(command: list[str]) -> list[str]:
    """`command` with the state flags of the network its --model names (compare_models.state_flags: the grid
    encoding, channels, previous choice, wall rays and person tokens the file says it reads), read when the command
    runs, after training wrote the file. Unchanged without --model or when the command already sets --dovs."""
    if "--model" not in command or "--dovs" in command:
        return command
    from .compare_models import state_flags  # noqa: PLC0415
    at = command.index("--model") + 2
    return command[:at] + state_flags(command[at - 1]) + command[at:]


def world_label(world: str, count: int) -> str:
    """The folder of one worlds evaluation, as scripts/benchmark_worlds.sh names them: FAMILY_nN."""
    return f"{world}_n{count}"


def _evaluations(s: Settings, methods: str, eval_dir: str, log_dir: str, model: str | None) -> list[Evaluation]:
    """The task's dqn_dovs_eval runs: one into eval_dir (log: log_dir/eval.log), or with --eval-worlds one per
    family and count into eval_dir/FAMILY_nN/ (its log there)."""
    if not s.eval_worlds:
        return [Evaluation("", _eval_command(s, methods, eval_dir, model), eval_dir, os.path.join(log_dir, EVAL_LOG))]
    out = []
    for world in s.eval_worlds:
        for n in eval_counts(s):
            d = os.path.join(eval_dir, world_label(world, n))
            out.append(Evaluation(world_label(world, n), _eval_command(s, methods, d, model, world, n), d,
                                  os.path.join(d, EVAL_LOG)))
    return out


def trial_specs(s: Settings) -> list[TrialSpec]:
    """The baselines and the reference first (short), then every configuration x seed."""
    env = _task_env(s)
    specs = []
    for method in s.baselines:
        d = os.path.join(s.out, BASELINES_DIR, method)
        specs.append(TrialSpec("baseline", method, None, d, _evaluations(s, method, d, d, None), env, s.cwd))
    if s.reference:
        d = os.path.join(s.out, REFERENCE_DIR)
        specs.append(TrialSpec("reference", REFERENCE, None, d, _evaluations(s, TRAINED_METHOD, d, d, s.reference),
                               env, s.cwd, model=s.reference))
    for c in s.configs:
        for seed in s.seeds:
            d = os.path.join(s.out, TRIALS_DIR, c.name, f"seed{seed}")
            run = os.path.join(d, RUN_DIR)
            model = os.path.join(run, s.model_file)
            train = [s.python, "-m", "dqn_dovs_py.train", "--config", c.path, "--out", run, "--seed", str(seed),
                     "--device", s.device, "--no-progress"]
            if s.scale is not None:
                train += ["--scale", repr(s.scale)]
            if s.init_from:
                train += ["--init-from", s.init_from]
            specs.append(TrialSpec("trial", c.name, seed, d,
                                   _evaluations(s, TRAINED_METHOD, os.path.join(d, EVAL_DIR), d, model), env, s.cwd,
                                   train_command=train, model=model))
    return specs


# ---- figures and the table ----------------------------------------------------------------------------------------


@dataclass
class RunFigures:
    """One evaluation's figures (report.summarize's mean row; with --eval-worlds the means over the family and
    count runs) and its episodes."""

    episodes: int
    successes: int
    success: float
    collision: float
    timeout: float
    records: list[Record] = field(repr=False, default_factory=list)
    at_fault: float = math.nan  # robot-at-fault collisions per episode; NaN when results.csv does not record them
    families: dict[str, tuple[float, float]] = field(default_factory=dict)  # family -> (success, at_fault)


def fault_rate(records: list[Record]) -> float:
    """The share of episodes that ended in a collision the robot is at fault for (results.csv's at_fault); NaN
    when a collision does not record it."""
    crashes = [r for r in records if r.outcome == "collision"]
    if not records or any(r.at_fault is None for r in crashes):
        return math.nan
    return sum(bool(r.at_fault) for r in crashes) / len(records)


def figures_of(path: str) -> RunFigures:
    """The figures of one single-method results.csv; ValueError naming the file on a malformed or mixed one."""
    records = read_results(path)
    methods = sorted({r.method for r in records})
    if len(methods) != 1:
        raise ValueError(f"{path}: expected the episodes of one method, found {', '.join(methods) or 'none'}")
    o = summarize(records, methods[0]).overall[methods[0]]
    counts = sorted({r.obstacles for r in records})
    at_fault = sum(fault_rate([r for r in records if r.obstacles == n]) for n in counts) / len(counts)
    return RunFigures(o.episodes, o.successes, o.success_rate, o.collision_rate, o.timeout_rate, records, at_fault)


def world_figures_of(files: dict[str, str]) -> RunFigures:
    """The figures of a --eval-worlds task from its results.csv per FAMILY_nN: each rate the mean over the runs, and
    per family the mean success and robot-at-fault rate over its counts; ValueError naming a file that cannot be
    read, or one method against another."""
    runs = {label: figures_of(path) for label, path in files.items()}
    methods = {label: run.records[0].method for label, run in runs.items()}
    if len(set(methods.values())) > 1:
        raise ValueError(f"the worlds evaluations hold different methods ({', '.join(sorted(set(methods.values())))}"
                         f": {', '.join(f'{files[k]} {m}' for k, m in methods.items())})")

    def mean(values) -> float:
        values = list(values)
        return sum(values) / len(values) if values else math.nan

    families: dict[str, list[RunFigures]] = {}
    for label, run in runs.items():
        families.setdefault(label.rsplit("_n", 1)[0], []).append(run)
    all_runs = list(runs.values())
    return RunFigures(sum(r.episodes for r in all_runs), sum(r.successes for r in all_runs),
                      mean(r.success for r in all_runs), mean(r.collision for r in all_runs),
                      mean(r.timeout for r in all_runs), [x for r in all_runs for x in r.records],
                      mean(r.at_fault for r in all_runs),
                      {f: (mean(r.success for r in rs), mean(r.at_fault for r in rs)) for f, rs in families.items()})


def outcome_figures(o: TrialOutcome) -> RunFigures:
    """The figures of a finished task: its results.csv, or with --eval-worlds every FAMILY_nN's."""
    return world_figures_of(o.world_results) if o.world_results else figures_of(o.results)


@dataclass
class Entry:
    """A row of the table: a configuration (its seeds' runs) or a baseline or the reference (one run for every
    seed, key None)."""

    kind: str  # "config", "baseline", "reference"
    name: str
    source: str  # the configuration file, the method, or the reference's weight file
    runs: dict[int | None, RunFigures] = field(default_factory=dict)
    failed: dict[int | None, str] = field(default_factory=dict)  # seed -> error
    rank: int | None = None

    def mean(self, attr: str) -> float:
        values = [getattr(r, attr) for r in self.runs.values()]
        return sum(values) / len(values) if values else math.nan

    def family_mean(self, family: str, index: int) -> float:
        """The mean over the seeds of a family's success (index 0) or robot-at-fault rate (1)."""
        values = [r.families[family][index] for r in self.runs.values() if family in r.families]
        return sum(values) / len(values) if values else math.nan


def paired_entries(a: Entry, b: Entry) -> Paired:
    """`a` against `b` on the same episodes, seed by seed (an entry without seeds pairs with each of the other's),
    pooled: episodes, wins (a succeeded, b did not), losses, and the sign test on them. Episodes are matched by
    scenario (which names the world family), count and episode number (worlds_report.paired)."""
    from .worlds_report import paired  # noqa: PLC0415 - it loads matplotlib; only the table needs it

    if None in a.runs and None in b.runs:
        pairs = [(a.runs[None], b.runs[None])]
    elif None in b.runs:
        pairs = [(r, b.runs[None]) for _, r in sorted(a.runs.items())]
    elif None in a.runs:
        pairs = [(a.runs[None], r) for _, r in sorted(b.runs.items())]
    else:
        pairs = [(a.runs[s], b.runs[s]) for s in sorted(set(a.runs) & set(b.runs))]
    total = Paired()
    for mine, theirs in pairs:
        records = [replace(r, method="a") for r in mine.records] + [replace(r, method="b") for r in theirs.records]
        one = paired(records, "a", "b", lambda r: r.outcome == "success")
        total.episodes += one.episodes
        total.wins += one.wins
        total.losses += one.losses
    total.p_value = sign_test_p(total.wins, total.losses)
    return total


def build_entries(s: Settings, outcomes: list[TrialOutcome]) -> tuple[list[Entry], list[Entry]]:
    """The configurations, ranked (rank None: no seed evaluated), and the comparators (baselines, reference). A
    results.csv that cannot be read turns its trial into a failed one."""
    configs = {c.name: Entry("config", c.name, c.path) for c in s.configs}
    comparators = {m: Entry("baseline", m, m) for m in s.baselines}
    if s.reference:
        comparators[REFERENCE] = Entry("reference", REFERENCE, s.reference)
    for o in outcomes:
        entry = configs[o.name] if o.kind == "trial" else comparators[o.name]
        if o.ok:
            try:
                entry.runs[o.seed] = outcome_figures(o)
                continue
            except ValueError as e:
                o.ok, o.error = False, f"cannot read the evaluation: {e}"
        entry.failed[o.seed] = o.error
    ranked = sorted((e for e in configs.values() if e.runs), key=lambda e: (-e.mean("success"), e.mean("collision"),
                                                                          e.name))
    for i, e in enumerate(ranked, 1):
        e.rank = i
    ranked += [e for e in configs.values() if not e.runs]
    return ranked, list(comparators.values())


def table_rows(s: Settings, configs: list[Entry], comparators: list[Entry]) -> list[dict]:
    """One dict per row of sweep.csv (configurations by rank, then the comparators): the figures, each seed's
    success, and the paired comparisons against the best configuration and each comparator."""
    best = configs[0] if configs and configs[0].rank == 1 else None
    rivals = ([("best", best)] if best else []) + [(c.name, c) for c in comparators]
    rows = []
    for e in configs + comparators:
        row: dict = {"rank": e.rank if e.rank is not None else "", "name": e.name, "kind": e.kind,
                     "source": e.source,
                     "seeds": " ".join(str(k) for k in sorted(e.runs) if k is not None) if e.kind == "config" else "",
                     "episodes": sum(r.episodes for r in e.runs.values()),
                     "success": e.mean("success"), "collision": e.mean("collision"), "timeout": e.mean("timeout"),
                     "at_fault": e.mean("at_fault")}
        for family in s.eval_worlds:
            row[f"success_{family}"] = e.family_mean(family, 0)
            row[f"at_fault_{family}"] = e.family_mean(family, 1)
        for seed in s.seeds:
            run = e.runs.get(seed) if e.kind == "config" else None
            row[f"success_seed{seed}"] = run.success if run else math.nan
        for label, rival in rivals:
            if rival is e or not e.runs or not rival.runs:
                p = None
            else:
                p = paired_entries(e, rival)
            row[f"vs_{label}_episodes"] = p.episodes if p else ""
            row[f"vs_{label}_wins"] = p.wins if p else ""
            row[f"vs_{label}_losses"] = p.losses if p else ""
            row[f"vs_{label}_p"] = p.p_value if p else math.nan
        status = "ok"
        if e.failed:
            status = "failed: " + "; ".join(f"{'' if k is None else f'seed {k}: '}{v}"
                                            for k, v in sorted(e.failed.items(), key=lambda kv: kv[0] or 0))
        row["status"] = status
        rows.append(row)
    return rows


def _num(x, digits: int = 3) -> str:
    if isinstance(x, float):
        return "" if math.isnan(x) else f"{x:.{digits}f}"
    return str(x)


def write_csv(path: str, rows: list[dict]) -> None:
    columns = list(rows[0]) if rows else ["rank", "name"]
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=columns)
        w.writeheader()
        for row in rows:
            w.writerow({k: (_num(v, 4) if k.endswith("_p") or isinstance(v, float) else v) for k, v in row.items()})


def _paired_cell(row: dict, label: str) -> str:
    if row.get(f"vs_{label}_episodes", "") in ("", None):
        return "-"
    p = row[f"vs_{label}_p"]
    mark = " *" if p < SIGNIFICANCE else ""
    return f"+{row[f'vs_{label}_wins']} / -{row[f'vs_{label}_losses']} (p = {p:.2g}){mark}"


def _and(items: list[str]) -> str:
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def render_markdown(s: Settings, rows: list[dict], outcomes: list[TrialOutcome], info: dict) -> str:
    counts = eval_counts(s)
    per_run = s.eval_episodes * len(counts) * max(1, len(s.eval_worlds))
    best = next((r for r in rows if r["rank"] == 1), None)
    rivals = (["best"] if best else []) + [r["name"] for r in rows if r["kind"] != "config"]
    flags = " ".join(f for f in s.eval_flags if f != "--perfect-info")
    world = f"`{flags}`" if flags else "the default room world"
    perception = "perfect information" if "--perfect-info" in s.eval_flags else "the tracker in the loop"
    shared = _and(["every trial"] + (["the baselines"] if s.baselines else []) + (["the reference"] if s.reference
                                                                                  else []))
    if s.eval_worlds:
        where = (f"in each of the world families {_and(s.eval_worlds)} at N = {_and([str(n) for n in counts])} "
                 f"(`dqn_dovs_eval --generate {s.eval_generate} --world FAMILY --obstacles N --episodes "
                 f"{s.eval_episodes}`" + (f", `{flags}`" if flags else "") + ")")
        means = ("Rates are means over the family and count runs (robot at fault: results.csv's `at_fault`); a "
                 "configuration's figures are the means over its seeds.")
    else:
        where = (f"(`dqn_dovs_eval --generate {s.eval_generate} --obstacles {s.eval_obstacles} --episodes "
                 f"{s.eval_episodes}`, {world})")
        means = "Rates are means over the obstacle counts; a configuration's figures are the means over its seeds."
    out = ["# Sweep", "",
           f"Written by `{info['command']}` on {info['date']} (commit `{info['commit']}`), on {info['ray']}.", "",
           f"Each trial trains one configuration with one seed, then evaluates its `{s.model_file}` as "
           f"`{TRAINED_METHOD}` with {perception} on held-out generated episodes {where}: {per_run} "
           f"episodes per trial, the same for {shared}. " + means, "",
           "## Ranking", "",
           "Ranked by mean success (ties: the lower mean collision rate). Paired columns: episodes the row's side "
           "solved and the other did not (+), the reverse (-), and the exact two-sided sign test on them; pairs are "
           "the same episode under the same trial seed, pooled over the seeds (a baseline's or the reference's "
           f"single run pairs with every seed's). `*`: p < {SIGNIFICANCE}."
           + (f" `best`: {best['name']}." if best else " No configuration was evaluated."), ""]
    header = (["rank", "configuration", "seeds", "success", "collision", "timeout"]
              + (["at fault"] if s.eval_worlds else []) + ["success per seed"]
              + [f"vs {r}" for r in rivals] + ["status"])
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for r in rows:
        per_seed = " / ".join(_num(r[f"success_seed{k}"]) or "failed" for k in s.seeds) if r["kind"] == "config" \
            else "-"
        name = f"`{r['name']}`" if r["kind"] == "config" else f"{r['kind']} `{r['name']}`"
        if r["kind"] == "reference":
            name = f"reference `{os.path.relpath(r['source'], s.cwd)}`"
        cells = [str(r["rank"]) or "-", name, r["seeds"] or "-", _num(r["success"]) or "-",
                 _num(r["collision"]) or "-", _num(r["timeout"]) or "-"]
        cells += ([_num(r["at_fault"]) or "-"] if s.eval_worlds else []) + [per_seed]
        cells += [_paired_cell(r, label) for label in rivals]
        cells.append("ok" if r["status"] == "ok" else "failed (below)")
        lines.append("| " + " | ".join(c.replace("|", "/") for c in cells) + " |")
    out += lines + [""]
    if s.eval_worlds:
        out += ["## Per family", "", "Success / robot-at-fault rate in each family, N pooled (means over the counts, "
                "then over the seeds).", "",
                "| configuration | " + " | ".join(s.eval_worlds) + " |", "|" + "---|" * (len(s.eval_worlds) + 1)]
        for r in rows:
            name = f"`{r['name']}`" if r["kind"] == "config" else f"{r['kind']} `{r['name']}`"
            cells = [f"{_num(r[f'success_{w}']) or '-'} / {_num(r[f'at_fault_{w}']) or '-'}" for w in s.eval_worlds]
            out.append(f"| {name} | " + " | ".join(cells) + " |")
        out += [""]
    out += ["## Trials", "",
            "| trial | success | collision | timeout | training (s) | evaluation (s) | wall (s) | node | folder |",
            "|---|---|---|---|---|---|---|---|---|"]
    figures = {(f["kind"], f["name"], f["seed"]): f for f in info["trials"]}
    for o in outcomes:
        f = figures[(o.kind, o.name, o.seed)]
        rel = os.path.relpath(o.directory, s.out)
        if o.ok:
            rates = [_num(f["success"]), _num(f["collision"]), _num(f["timeout"])]
        else:
            rates = ["failed", "-", "-"]
        train = f"{o.train_s:.1f}" if o.kind == "trial" else "-"
        out.append(f"| {o.label()} | " + " | ".join(rates) + f" | {train} | {o.eval_s:.1f} | {o.wall_s:.1f} | "
                   f"{o.node} | `{rel}` |")
    failed = [o for o in outcomes if not o.ok]
    if failed:
        out += ["", "## Failed trials", ""]
        out += [f"- {o.label()}: {o.error}" for o in failed]
    out += ["", f"Figures: `{SWEEP_CSV}`, `{SWEEP_JSON}`; each trial's logs, run and evaluation in its folder.", ""]
    return "\n".join(out)


def _commit() -> str:
    try:
        return subprocess.run(["git", "-C", REPO_ROOT, "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True, timeout=10, check=True).stdout.strip() or "not recorded"
    except (OSError, subprocess.SubprocessError):
        return "not recorded"


def _jsonable(x):
    if isinstance(x, float) and math.isnan(x):
        return None
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_jsonable(v) for v in x]
    return x


def write_outputs(s: Settings, outcomes: list[TrialOutcome], info: dict) -> list[dict]:
    """sweep.csv, sweep.md and sweep.json in OUT; returns the table's rows."""
    configs, comparators = build_entries(s, outcomes)
    rows = table_rows(s, configs, comparators)
    entries = {("trial" if e.kind == "config" else e.kind, e.name): e for e in configs + comparators}
    trials = []
    for o in outcomes:
        run = entries[(o.kind, o.name)].runs.get(o.seed) if o.ok else None
        trials.append({**asdict(o), "episodes": run.episodes if run else 0, "successes": run.successes if run else 0,
                       "success": run.success if run else math.nan, "collision": run.collision if run else math.nan,
                       "timeout": run.timeout if run else math.nan, "at_fault": run.at_fault if run else math.nan})
    info = dict(info, trials=trials)
    write_csv(os.path.join(s.out, SWEEP_CSV), rows)
    with open(os.path.join(s.out, SWEEP_MD), "w") as f:
        f.write(render_markdown(s, rows, outcomes, info))
    with open(os.path.join(s.out, SWEEP_JSON), "w") as f:
        json.dump(_jsonable(dict(info, settings=asdict(s), table=rows,
                                 failed=sum(not o.ok for o in outcomes))), f, indent=2)
        f.write("\n")
    return rows


# ---- Ray ----------------------------------------------------------------------------------------------------------


def start_ray(s: Settings):
    """Ray on this machine (a new local instance) or the cluster at --address; returns the module."""
    try:
        import ray  # noqa: PLC0415 - only the sweep needs it
    except ImportError as e:
        raise SweepError(f"Ray is not installed ({e}): run 'make setup' (python/requirements.txt)") from None
    import logging  # noqa: PLC0415

    # The workers import this package (the task's function) from the driver's source tree.
    runtime_env = {"env_vars": {"PYTHONPATH": _task_env(s)["PYTHONPATH"]}}
    common = dict(log_to_driver=False, logging_level=logging.WARNING, runtime_env=runtime_env)
    try:
        if s.address is None:
            ray.init(address="local", num_cpus=s.num_cpus, include_dashboard=False,
                     object_store_memory=LOCAL_OBJECT_STORE_BYTES, **common)
        else:
            ray.init(address=s.address, **common)
    except Exception as e:  # noqa: BLE001 - Ray's errors differ by cause and version; each one is reported
        where = f"the Ray cluster at {s.address}" if s.address else "a local Ray instance"
        hint = ""
        if s.address and not os.environ.get("RAY_AUTH_MODE"):
            hint = ("; a cluster with token authentication also needs RAY_AUTH_MODE=token and its token "
                    "(RAY_AUTH_TOKEN or ~/.ray/auth_token) in this environment")
        raise SweepError(f"cannot start or join {where}: {e}{hint}") from None
    return ray


def _progress_line(done: int, total: int, o: TrialOutcome) -> str:
    head = f"sweep: [{done}/{total}] {o.label()}"
    if not o.ok:
        return f"{head} FAILED after {o.wall_s:.1f} s: {o.error}"
    try:
        f = outcome_figures(o)
    except ValueError as e:
        return f"{head} FAILED after {o.wall_s:.1f} s: cannot read the evaluation: {e}"
    timing = f"eval {o.eval_s:.1f} s" if o.kind != "trial" else f"train {o.train_s:.1f} s, eval {o.eval_s:.1f} s"
    fault = "" if math.isnan(f.at_fault) else f", at fault {f.at_fault:.3f}"
    return (f"{head}: success {f.success:.3f}, collision {f.collision:.3f}, timeout {f.timeout:.3f}{fault} "
            f"({timing}, wall {o.wall_s:.1f} s, {o.node})")


def run_sweep(s: Settings, command: str) -> int:
    """Runs every task on Ray, prints a line as each finishes, writes the outputs; 1 when a trial failed."""
    specs = trial_specs(s)
    os.makedirs(s.out, exist_ok=True)
    ray = start_ray(s)
    t0 = time.perf_counter()
    try:
        resources = {k: v for k, v in ray.cluster_resources().items() if k in ("CPU", "GPU")}
        where = (f"Ray cluster {s.address}" if s.address else "local Ray") + \
            f" ({', '.join(f'{v:g} {k}' for k, v in resources.items())})"
        trials = sum(spec.kind == "trial" for spec in specs)
        print(f"sweep: {len(s.configs)} configuration(s) x {len(s.seeds)} seed(s) = {trials} trial(s) and "
              f"{len(specs) - trials} comparator evaluation(s) on {where}; folder {s.out}", flush=True)
        task = ray.remote(run_trial).options(num_cpus=s.cpus_per_trial, num_gpus=s.gpus_per_trial, max_retries=0)
        pending = {task.remote(spec): spec for spec in specs}
        outcomes: dict[int, TrialOutcome] = {}
        order = {id(spec): i for i, spec in enumerate(specs)}
        try:
            while pending:
                ready, _ = ray.wait(list(pending), num_returns=1)
                spec = pending.pop(ready[0])
                try:
                    outcome = ray.get(ready[0])
                except Exception as e:  # noqa: BLE001 - a task that Ray lost (worker killed, node gone, out of memory)
                    outcome = TrialOutcome(spec.kind, spec.name, spec.seed, spec.directory, model=spec.model,
                                           error=f"the Ray task failed: {type(e).__name__}: "
                                                 f"{str(e).strip().splitlines()[-1] if str(e).strip() else ''}")
                outcomes[order[id(spec)]] = outcome
                print(_progress_line(len(outcomes), len(specs), outcome), flush=True)
        except KeyboardInterrupt:
            for ref in pending:
                ray.cancel(ref, force=True)
            raise
        ordered = [outcomes[i] for i in range(len(specs))]
        info = {"command": command, "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
                "commit": _commit(), "ray": where, "wall_s": time.perf_counter() - t0}
        rows = write_outputs(s, ordered, info)
    finally:
        ray.shutdown()
    print(f"sweep: done in {time.perf_counter() - t0:.0f} s; ranking by mean success:")
    for r in rows:
        if r["kind"] == "config" and r["rank"] != "":
            print(f"  {r['rank']}. {r['success']:.3f}  {r['name']}")
    for r in rows:
        if r["kind"] != "config" and r["episodes"]:
            print(f"  -  {r['success']:.3f}  {r['kind']} {r['source']}")
    print(f"sweep: wrote {os.path.join(s.out, SWEEP_MD)}, {SWEEP_CSV}, {SWEEP_JSON}")
    failed = [o for o in ordered if not o.ok]
    if failed:
        print(f"sweep: {len(failed)} of {len(ordered)} trial(s) failed:", file=sys.stderr)
        for o in failed:
            print(f"  {o.label()}: {o.error}", file=sys.stderr)
        return 1
    return 0


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    argv_list = sys.argv[1:] if argv is None else argv
    try:
        settings = settings_from(args)
        return run_sweep(settings, "python -m dqn_dovs_py.sweep " + " ".join(shlex.quote(a) for a in argv_list))
    except SweepError as e:
        print(f"sweep: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"sweep: interrupted; the running trials were stopped (their folders stay in {args.out})",
              file=sys.stderr)
        return 130


if __name__ == "__main__":
    # The package's module rather than this __main__ copy, so that Ray sends the task's function to the workers by
    # its name (dqn_dovs_py.sweep.run_trial), not pickled with this script's globals.
    from dqn_dovs_py.sweep import main as _main

    sys.exit(_main())
