"""Learning curves of a training run as PNG: `python -m dqn_dovs_py.plots runs/NAME`.

Reads the run's train_log.csv and eval_log.csv (written by dqn_dovs_py.train) and draws
returns, outcome rates, loss and epsilon over episodes, and the greedy evaluations,
with the curriculum's stage boundaries marked.
"""

from __future__ import annotations

import argparse
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 - the backend must be chosen first
import numpy as np  # noqa: E402

PNG_NAME = "learning_curves.png"


def _read_csv(path: str) -> dict[str, list[str]]:
    if not os.path.exists(path):
        return {}
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        return {}
    return {k: [r[k] for r in rows] for k in rows[0]}


def _floats(values: list[str]) -> np.ndarray:
    return np.array([float(v) if v not in ("", None) else np.nan for v in values], float)


def moving_average(values: np.ndarray, window: int) -> np.ndarray:
    """Trailing mean over up to `window` values, ignoring NaN (NaN where none is finite)."""
    finite = np.isfinite(values)
    sums = np.concatenate([[0.0], np.cumsum(np.where(finite, values, 0.0))])
    counts = np.concatenate([[0], np.cumsum(finite)])
    hi = np.arange(1, len(values) + 1)
    lo = np.maximum(hi - window, 0)
    n = counts[hi] - counts[lo]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, (sums[hi] - sums[lo]) / np.maximum(n, 1), np.nan)


def plot_run(run_dir: str, curriculum=None, out: str | None = None, window: int = 100) -> str | None:
    """Writes the run's learning curves; returns the PNG path, or None when nothing is logged yet."""
    train = _read_csv(os.path.join(run_dir, "train_log.csv"))
    if not train:
        return None
    evals = _read_csv(os.path.join(run_dir, "eval_log.csv"))
    episode = _floats(train["episode"])
    stage = _floats(train["stage"])
    window = max(1, min(window, len(episode)))

    fig, axes = plt.subplots(2, 2, figsize=(13, 8), sharex=True)
    ax_ret, ax_out, ax_loss, ax_eval = axes.ravel()

    ret = _floats(train["return"])
    ax_ret.plot(episode, ret, color="tab:blue", alpha=0.2, lw=0.6)
    ax_ret.plot(episode, moving_average(ret, window), color="tab:blue", lw=1.5, label=f"mean of {window}")
    ax_ret.set_ylabel("episode return")
    ax_ret.legend(loc="lower right")

    outcome = np.array(train["outcome"])
    for name, colour in (("success", "tab:green"), ("collision", "tab:red"), ("timeout", "tab:orange")):
        ax_out.plot(episode, moving_average((outcome == name).astype(float), window), color=colour, label=name)
    ax_out.set_ylabel(f"outcome rate ({window} episodes)")
    ax_out.set_ylim(-0.02, 1.02)
    ax_out.legend(loc="best", fontsize=8)

    loss = _floats(train["loss"])
    if np.any(np.isfinite(loss) & (loss > 0)):
        ax_loss.plot(episode, moving_average(loss, window), color="tab:purple", label="loss")
        ax_loss.set_yscale("log")
    ax_loss.set_ylabel("Huber loss (IS-weighted)")
    ax_loss.set_xlabel("episode")
    ax_eps = ax_loss.twinx()
    ax_eps.plot(episode, _floats(train["epsilon"]), color="tab:gray", lw=1.0, label="epsilon")
    ax_eps.set_ylabel("epsilon")
    ax_eps.set_ylim(0, 1.05)

    if evals:
        e_ep = _floats(evals["episode"])
        for key, colour in (("success_rate", "tab:green"), ("collision_rate", "tab:red"),
                            ("timeout_rate", "tab:orange")):
            ax_eval.plot(e_ep, _floats(evals[key]), marker="o", ms=3, color=colour, label=key.replace("_", " "))
        ax_eval.legend(loc="best", fontsize=8)
    ax_eval.set_ylabel("greedy evaluation")
    ax_eval.set_ylim(-0.02, 1.02)
    ax_eval.set_xlabel("episode")

    # Stage boundaries: from the curriculum when given, else where the logged stage changes.
    if curriculum is not None:
        starts = [curriculum.stage_start(i) for i in range(1, len(curriculum.stages))]
        names = [s.name for s in curriculum.stages]
    else:
        change = np.flatnonzero(np.diff(stage) != 0) + 1
        starts = [float(episode[i]) for i in change]
        names = []
    for ax in axes.ravel():
        for x in starts:
            ax.axvline(x, color="k", lw=0.6, ls=":")
        ax.grid(alpha=0.3)
    if names:
        bounds = [0] + starts + [curriculum.total_episodes]
        for name, a, b in zip(names, bounds[:-1], bounds[1:]):
            ax_ret.text((a + b) / 2, 1.01, name, transform=ax_ret.get_xaxis_transform(), ha="center",
                        va="bottom", fontsize=7)

    fig.suptitle(f"DQN-DOVS training: {os.path.basename(os.path.abspath(run_dir))}")
    fig.tight_layout()
    path = out or os.path.join(run_dir, PNG_NAME)
    fig.savefig(path + ".tmp.png", dpi=110)
    plt.close(fig)
    os.replace(path + ".tmp.png", path)
    return path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m dqn_dovs_py.plots", description=__doc__.splitlines()[0])
    parser.add_argument("run_dir", help="training run directory (holds train_log.csv)")
    parser.add_argument("--out", help=f"PNG path (default RUN_DIR/{PNG_NAME})")
    parser.add_argument("--window", type=int, default=100, help="episodes in the moving averages")
    args = parser.parse_args(argv)
    path = plot_run(args.run_dir, out=args.out, window=args.window)
    if path is None:
        print(f"error: {os.path.join(args.run_dir, 'train_log.csv')} is missing or empty", file=sys.stderr)
        return 1
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
