"""A learned prediction of walking people's next seconds, for the oracle's diagnostic and the planners' predicted arcs.

Trains a small multilayer perceptron that corrects a constant-velocity extrapolation of each person from what can be
seen now: the person's last second of positions, its nearest neighbours' positions and velocities, and the walls
around it (8 rays from the person, every 45 deg from its direction of motion). Training data are the paths that
``dqn_dovs_eval`` writes (paths.json, one position per control period) in any world family: people in buildings and
the paper's discs alike; the network is exported in the format ``PeoplePredictor::load`` reads
(include/dqn_dovs/evaluation/people_predictor.h, version 2). The features here and in people_predictor.cpp are the
same, item by item; test/python/test_people_predictor.py holds them to it through the C++ inference.

    python -m dqn_dovs_py.people_predictor --train DIR [DIR ...] --valid DIR [DIR ...] --out FILE.dqnp
"""

from __future__ import annotations

import argparse
import json
import struct
import sys
import time
from pathlib import Path

import numpy as np

from . import provenance

MAGIC = b"DQNDPPv2"
HISTORY = 5  # steps of the past (1 s at 0.2 s)
FUTURE = 10  # steps predicted (2 s)
NEIGHBOURS = 6
FAR = 10.0  # position of a missing neighbour (m, straight ahead)
WALL_RAY_RANGE = 5.0  # reach of the wall rays (m): PeoplePredictor::kWallRayRange_m
V1_AXIS_RANGE = 10.0  # a version 1 file's offset along an axis without a wall (m)


class PredictorDataError(ValueError):
    """Training data that cannot be used; the message names the file and the reason."""


def input_size(history: int = HISTORY, neighbours: int = NEIGHBOURS) -> int:
    return 2 * history + 1 + 5 * neighbours + 8


def _frames(tracks: np.ndarray, step_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Velocity (last step) and unit direction of motion of every person; tracks: people x (history + 1) x 2."""
    velocity = (tracks[:, -1] - tracks[:, -2]) / step_s
    speed = np.linalg.norm(velocity, axis=1)
    walked = tracks[:, -1] - tracks[:, 0]
    walked_norm = np.linalg.norm(walked, axis=1)
    along = np.tile(np.array([1.0, 0.0]), (len(tracks), 1))
    moving = speed > 1e-3
    along[moving] = velocity[moving] / speed[moving, None]
    drifted = ~moving & (walked_norm > 1e-6)
    along[drifted] = walked[drifted] / walked_norm[drifted, None]
    return velocity, along


def _to_frame(along: np.ndarray, w: np.ndarray) -> np.ndarray:
    """w (... x 2) in the frame whose x axis is `along` (2,): _rotate_into for one person."""
    return _rotate_into(np.asarray(along)[None], np.asarray(w)[None])[0]


def first_wall(origins: np.ndarray, directions: np.ndarray, walls: np.ndarray, reach: float) -> np.ndarray:
    """Distance from each origin (P x 2) along each of its unit directions (P x K x 2) to the first wall (segments
    M x 4: ax ay bx by), `reach` where none is nearer (P x K); the arithmetic of the C++ raySegment."""
    if len(walls) == 0:
        return np.full(directions.shape[:2], reach)
    a, e = walls[:, :2], walls[:, 2:] - walls[:, :2]
    d = directions[:, :, None, :]
    denom = d[..., 0] * e[:, 1] - d[..., 1] * e[:, 0]
    ao = (a[None] - origins[:, None])[:, None]  # P x 1 x M x 2
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (ao[..., 0] * e[:, 1] - ao[..., 1] * e[:, 0]) / denom
        u = (ao[..., 0] * d[..., 1] - ao[..., 1] * d[..., 0]) / denom
    hit = (np.abs(denom) >= 1e-12) & (t >= 0.0) & (u >= 0.0) & (u <= 1.0)
    return np.minimum(np.where(hit, t, np.inf).min(axis=2), reach)


def square_room(half_size_m: float) -> np.ndarray:
    """The four walls of the square room x, y = +-h (segments M x 4)."""
    h = half_size_m
    return np.array([[-h, -h, h, -h], [h, -h, h, h], [h, h, -h, h], [-h, h, -h, -h]], dtype=np.float64)


def episode_walls(episode: dict) -> np.ndarray:
    """The walls of a paths.json episode as the simulator has them: its room's four, then its extra segments."""
    extra = np.asarray(episode.get("walls", []), dtype=np.float64).reshape(-1, 4)
    return np.concatenate([square_room(float(episode["room_half_size_m"])), extra])


_RAYS = np.stack([np.cos(np.arange(8) * np.pi / 4.0), np.sin(np.arange(8) * np.pi / 4.0)], 1)
_AXES = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])


def _rotate_into(along: np.ndarray, w: np.ndarray) -> np.ndarray:
    """w (P x ... x 2) in the frames whose x axes are along (P x 2), person by person."""
    a = along.reshape(along.shape[:1] + (1,) * (w.ndim - 2) + (2,))
    return np.stack([a[..., 0] * w[..., 0] + a[..., 1] * w[..., 1], -a[..., 1] * w[..., 0] + a[..., 0] * w[..., 1]],
                    -1)


def _wall_inputs(now: np.ndarray, along: np.ndarray, walls: np.ndarray, version: int) -> np.ndarray:
    n = len(now)
    if version == 1:
        axes = np.broadcast_to(_AXES, (n, 4, 2))
        reach = first_wall(now, axes, walls, V1_AXIS_RANGE)
        return _rotate_into(along, axes * reach[..., None]).reshape(n, 8)
    directions = np.stack([along[:, None, 0] * _RAYS[:, 0] - along[:, None, 1] * _RAYS[:, 1],
                           along[:, None, 1] * _RAYS[:, 0] + along[:, None, 0] * _RAYS[:, 1]], -1)
    return first_wall(now, directions, walls, WALL_RAY_RANGE)


def features(tracks: np.ndarray, walls: np.ndarray, step_s: float, neighbours: int = NEIGHBOURS,
             version: int = 2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Inputs of every person (people x input_size), their velocities and directions of motion; walls: segments
    (M x 4) in the tracks' frame."""
    velocity, along = _frames(tracks, step_s)
    now = tracks[:, -1]
    n = len(tracks)
    own = _rotate_into(along, tracks[:, :-1] - now[:, None]).reshape(n, -1)
    dist = np.linalg.norm(now[None] - now[:, None], axis=2)
    np.fill_diagonal(dist, np.inf)
    taken = max(0, min(neighbours, n - 1))
    order = np.argsort(dist, axis=1, kind="stable")[:, :taken]  # the others by distance, ties by index, as C++
    nb = np.zeros((n, neighbours, 5))
    nb[:, :, 0] = FAR
    nb[:, :taken, :2] = _rotate_into(along, now[order] - now[:, None])
    nb[:, :taken, 2:4] = _rotate_into(along, velocity[order] - velocity[:, None])
    nb[:, :taken, 4] = 1.0
    rows = np.concatenate([own, np.linalg.norm(velocity, axis=1)[:, None], nb.reshape(n, -1),
                           _wall_inputs(now, along, walls, version)], axis=1)
    return rows, velocity, along


def _episodes(paths: Path) -> list:
    try:
        return json.loads(paths.read_text())["episodes"]
    except (OSError, ValueError, KeyError) as e:
        raise PredictorDataError(f"{paths}: not a paths.json of dqn_dovs_eval ({e})") from e


def _walking(episode: dict) -> np.ndarray | None:
    """The true paths of the people (not the static obstacles), cut to the shortest: people x steps x 2."""
    walking = [np.asarray(o["path"], dtype=np.float64) for o in episode["obstacle_paths"] if not o["static"]]
    if not walking:
        return None
    length = min(len(p) for p in walking)
    return np.stack([p[:length, :2] for p in walking])


def samples_from_paths(paths: Path, step_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(inputs, targets, constant-velocity targets) of every walking person at every step of every episode of a
    paths.json with a full history and future; targets are positions at the next FUTURE steps in the person's frame."""
    episodes = _episodes(paths)
    xs, ys, cvs = [], [], []
    steps = np.arange(1, FUTURE + 1) * step_s
    for e in episodes:
        A = _walking(e)
        if A is None or A.shape[1] < HISTORY + FUTURE + 1:
            continue
        walls = episode_walls(e)
        length = A.shape[1]
        for t in range(HISTORY, length - FUTURE):
            x, v, along = features(A[:, t - HISTORY:t + 1], walls, step_s)
            xs.append(x)
            ys.append(_rotate_into(along, A[:, t + 1:t + FUTURE + 1] - A[:, t, None]).reshape(len(A), -1))
            cvs.append(_rotate_into(along, v[:, None] * steps[None, :, None]).reshape(len(A), -1))
    if not xs:
        raise PredictorDataError(f"{paths}: no person walks long enough ({HISTORY + FUTURE + 1} steps)")
    return tuple(np.concatenate(a).astype(np.float32) for a in (xs, ys, cvs))


def track_histories(decisions: list, step_s: float):
    """For every decision of an episode's "tracks" (per step: [id, x, y, speed, heading, static] of each confirmed
    track), the moving tracks' last HISTORY + 1 positions as PredictedArcs keeps them (include/dqn_dovs/evaluation/
    people_predictor.h): by id, afresh when an id was missing at the decision before, walked back at the track's
    reported velocity where it is younger. Yields (step index, array tracks x (HISTORY + 1) x 2)."""
    history: dict[int, list] = {}
    for k, tracks in enumerate(decisions):
        seen = {}
        rows = []
        for t in tracks:
            if t[5]:
                continue
            h = history.get(int(t[0]), []) + [np.array(t[1:3], dtype=np.float64)]
            seen[int(t[0])] = h[-(HISTORY + 1):]
            velocity = t[3] * np.array([np.cos(t[4]), np.sin(t[4])])
            h = seen[int(t[0])]
            rows.append([h[len(h) - 1 - back] if back < len(h) else np.array(t[1:3]) - back * step_s * velocity
                         for back in range(HISTORY, -1, -1)])
        history = seen
        yield k, np.array(rows, dtype=np.float64).reshape(len(rows), HISTORY + 1, 2)


def samples_from_tracks(paths: Path, step_s: float, match_m: float = 0.5):
    """(inputs, targets, constant-velocity targets) as samples_from_paths, with the inputs from the tracker's tracks
    (the paths.json "tracks" of a run with the tracker in the loop) and the targets from the person each track
    follows (the nearest within match_m): where that person will be, from the track's present position."""
    episodes = _episodes(paths)
    xs, ys, cvs = [], [], []
    ahead = np.arange(1, FUTURE + 1) * step_s
    for e in episodes:
        if "tracks" not in e:
            raise PredictorDataError(f"{paths}: no tracks (a run with --perfect-info, or before tracks were recorded)")
        A = _walking(e)
        if A is None:
            continue
        walls = episode_walls(e)
        length = A.shape[1]
        for k, tracks in track_histories(e["tracks"][:length], step_s):
            if k + FUTURE >= length or len(tracks) == 0:
                continue
            x, velocity, along = features(tracks, walls, step_s)
            d = np.linalg.norm(A[None, :, k] - tracks[:, None, -1], axis=2)  # tracks x people
            person = np.argmin(d, axis=1)
            kept = d[np.arange(len(tracks)), person] <= match_m
            if not kept.any():
                continue
            future = A[person[kept], k + 1:k + FUTURE + 1] - tracks[kept, None, -1]
            xs.append(x[kept])
            ys.append(_rotate_into(along[kept], future).reshape(int(kept.sum()), -1))
            cvs.append(_rotate_into(along[kept], velocity[kept, None] * ahead[None, :, None]).reshape(
                int(kept.sum()), -1))
    if not xs:
        raise PredictorDataError(f"{paths}: no track follows a person")
    return tuple(np.concatenate(a).astype(np.float32) for a in (xs, ys, cvs))


def load_parts(dirs: list[Path], step_s: float, inputs: str = "truth") -> list:
    """The samples of each folder (inputs, targets, constant-velocity targets)."""
    take = samples_from_tracks if inputs == "tracks" else samples_from_paths
    return [take(Path(d) / "paths.json", step_s) for d in dirs]


def concatenate(parts: list) -> tuple:
    return tuple(np.concatenate([p[k] for p in parts]) for k in range(3))


def load_dirs(dirs: list[Path], step_s: float, inputs: str = "truth"):
    return concatenate(load_parts(dirs, step_s, inputs))


def family_of(folder: str) -> str:
    """The world family a data folder holds: its name up to the first '_' (train_people_predictor.sh's names)."""
    return Path(folder).name.split("_")[0]


def errors(pred: np.ndarray, target: np.ndarray, step_s: float) -> dict:
    """Mean displacement errors (m): average over the future, and at 0.6, 1 and 2 s (final)."""
    e = np.linalg.norm((pred - target).reshape(len(target), -1, 2), axis=2)
    at = lambda s: float(e[:, min(FUTURE, int(round(s / step_s))) - 1].mean())  # noqa: E731
    return {"ade": float(e.mean()), "at_0.6s": at(0.6), "at_1s": at(1.0), "at_2s": at(FUTURE * step_s),
            "p90_at_2s": float(np.quantile(e[:, -1], 0.9))}


def train(train_xyc, valid_xyc, hidden=(128, 128, 128), epochs=10, seed=0, log=print):
    import torch

    torch.manual_seed(seed)
    Xtr, Ytr, Ctr = (torch.tensor(a) for a in train_xyc)
    Xva, Yva, Cva = (torch.tensor(a) for a in valid_xyc)
    mean, scale = Xtr.mean(0), Xtr.std(0) + 1e-3
    layers, width = [], Xtr.shape[1]
    for h in hidden:
        layers += [torch.nn.Linear(width, h), torch.nn.ReLU()]
        width = h
    layers.append(torch.nn.Linear(width, Ytr.shape[1]))
    net = torch.nn.Sequential(*layers)
    opt = torch.optim.Adam(net.parameters(), 1e-3)
    n = len(Xtr)
    history = []
    for epoch in range(epochs):
        if epoch == int(0.7 * epochs):
            for g in opt.param_groups:
                g["lr"] = 3e-4
        perm = torch.randperm(n)
        for b in range(0, n, 512):
            idx = perm[b:b + 512]
            out = Ctr[idx] + net((Xtr[idx] - mean) / scale)
            loss = torch.nn.functional.smooth_l1_loss(out, Ytr[idx], beta=0.1)
            opt.zero_grad()
            loss.backward()
            opt.step()
        with torch.no_grad():
            e = errors((Cva + net((Xva - mean) / scale)).numpy(), Yva.numpy(), 0.2)
        history.append(e)
        log(f"epoch {epoch + 1}/{epochs}: validation ADE {e['ade']:.3f} m, at 2 s {e['at_2s']:.3f} m")
    return net, mean.numpy(), scale.numpy(), history


def export(path: Path, net, mean: np.ndarray, scale: np.ndarray, step_s: float) -> None:
    import torch

    linears = [m for m in net if isinstance(m, torch.nn.Linear)]
    out = bytearray(MAGIC)
    out += struct.pack("<5I", HISTORY, FUTURE, NEIGHBOURS, int(round(step_s * 1000)), len(linears))
    for m in linears:
        out += struct.pack("<2I", m.out_features, m.in_features)
    out += np.asarray(mean, "<f4").tobytes() + np.asarray(scale, "<f4").tobytes()
    for m in linears:
        out += m.weight.detach().numpy().astype("<f4").tobytes() + m.bias.detach().numpy().astype("<f4").tobytes()
    Path(path).write_bytes(bytes(out))


def load(path: Path) -> dict:
    """A predictor file as numpy arrays (the format people_predictor.h describes); ValueError naming the file."""
    b = Path(path).read_bytes()
    if b[:8] not in (MAGIC, b"DQNDPPv1"):
        raise ValueError(f"{path}: not a people predictor file")
    history, future, neighbours, step_ms, count = struct.unpack_from("<5I", b, 8)
    off = 28
    shapes = [struct.unpack_from("<2I", b, off + 8 * k) for k in range(count)]
    off += 8 * count
    n_in = shapes[0][1]
    mean = np.frombuffer(b, "<f4", n_in, off)
    scale = np.frombuffer(b, "<f4", n_in, off + 4 * n_in)
    off += 8 * n_in
    layers = []
    for outputs, inputs in shapes:
        w = np.frombuffer(b, "<f4", outputs * inputs, off).reshape(outputs, inputs)
        off += 4 * outputs * inputs
        layers.append((w, np.frombuffer(b, "<f4", outputs, off)))
        off += 4 * outputs
    if off != len(b):
        raise ValueError(f"{path}: {len(b) - off} bytes follow the last layer")
    return {"version": int(b[7:8]), "history": history, "future": future, "neighbours": neighbours,
            "step_s": step_ms / 1000.0, "mean": mean, "scale": scale, "layers": layers}


def predict(model: dict, tracks: np.ndarray, walls: np.ndarray) -> np.ndarray:
    """Every person's predicted positions (people x future x 2, the tracks' frame) from tracks (people x (history +
    1) x 2) among walls (segments M x 4), in numpy: the reference the C++ PeoplePredictor is held to."""
    step = model["step_s"]
    x, velocity, along = features(tracks, walls, step, model["neighbours"], model["version"])
    a = (x - model["mean"]) / model["scale"]
    for k, (w, b) in enumerate(model["layers"]):
        a = a @ w.T + b
        if k + 1 < len(model["layers"]):
            a = np.maximum(a, 0.0)
    ahead = np.arange(1, model["future"] + 1) * step
    out = np.zeros((len(tracks), model["future"], 2))
    for i in range(len(tracks)):
        f = _to_frame(along[i], np.outer(ahead, velocity[i])) + a[i].reshape(-1, 2)
        u = along[i]
        out[i] = tracks[i, -1] + np.stack([u[0] * f[:, 0] - u[1] * f[:, 1], u[1] * f[:, 0] + u[0] * f[:, 1]], 1)
    return out


def config_text(a: argparse.Namespace) -> str:
    """The provenance's `config` of a training run: every option but the seed and the output, the folders by their
    repository paths."""
    folders = {k: " ".join(provenance.repo_path(d) for d in getattr(a, k)) for k in ("train", "valid")}
    return (f"people_predictor --inputs {a.inputs} --epochs {a.epochs} --hidden {a.hidden} --step {a.step:g} "
            f"--train {folders['train']} --valid {folders['valid']}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--train", nargs="+", required=True, help="dqn_dovs_eval output folders (paths.json) to train on")
    ap.add_argument("--valid", nargs="+", required=True, help="folders to measure on (other seeds)")
    ap.add_argument("--out", required=True, help="predictor file to write (.dqnp)")
    ap.add_argument("--epochs", type=int, default=10)
    ap.add_argument("--hidden", default="128,128,128", help="hidden layer widths")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--step", type=float, default=0.2, help="seconds between the path's positions (control period)")
    ap.add_argument("--inputs", choices=("truth", "tracks"), default="truth",
                    help="learn from the people's true past (truth) or from the tracker's tracks of them (tracks)")
    a = ap.parse_args(argv)
    import torch

    torch.set_num_threads(2)
    t0 = time.time()
    try:
        tr = load_dirs(a.train, a.step, a.inputs)
        valid_parts = load_parts(a.valid, a.step, a.inputs)
    except PredictorDataError as e:
        print(f"people_predictor: {e}", file=sys.stderr)
        return 2
    va = concatenate(valid_parts)
    print(f"{len(tr[0])} training and {len(va[0])} validation samples ({time.time() - t0:.0f} s)", flush=True)
    cv = errors(va[2], va[1], a.step)
    net, mean, scale, history = train(tr, va, tuple(int(h) for h in a.hidden.split(",")), a.epochs, a.seed,
                                      log=lambda m: print(m, flush=True))
    export(Path(a.out), net, mean, scale, a.step)
    per_family = {}
    for family in dict.fromkeys(family_of(d) for d in a.valid):
        x, y, c = concatenate([p for d, p in zip(a.valid, valid_parts) if family_of(d) == family])
        with torch.no_grad():
            learned = c + net(torch.tensor((x - mean) / scale, dtype=torch.float32)).numpy()
        per_family[family] = {"samples": len(x), "constant_velocity": errors(c, y, a.step),
                              "learned": errors(learned, y, a.step)}
    summary = {"inputs": a.inputs, "constant_velocity": cv, "learned": history[-1], "train_samples": len(tr[0]),
               "valid_samples": len(va[0]), "per_family": per_family, "seconds": round(time.time() - t0, 1),
               # The .dqnp format has no metadata: its provenance (dqn_dovs_py.provenance) is kept here.
               "metadata": provenance.lines(provenance.make(config_text(a), a.seed))}
    Path(a.out).with_suffix(".json").write_text(json.dumps(summary, indent=2) + "\n")
    print(json.dumps(summary, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
