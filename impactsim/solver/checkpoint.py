"""Checkpoints: the whole state of a run in one .npz file, and a run resumed from it.

What is saved: everything reachable from the Simulation (the Model's arrays and scalars, the
integrator's buffers and step history, every pass and the objects they hold: contact rows and
surfaces, fracture state, particles, hashes...), found by walking the objects' attributes, so
that a new array in the model or a pass is saved without being listed here. Leaves are numpy
arrays (saved as they are), Python and numpy scalars, strings and None (0-d arrays with a type
tag), and lists, tuples, deques and dicts of them (recursively). Objects are entered when their
class is impactsim's own; other objects (thread pools, numba dispatchers, paths, dtypes, the case) are
configuration rebuilt from the case: they are not saved and keep the value the fresh state has; so
do the attributes a class names in ``CHECKPOINT_TRANSIENT`` (what a pass rebuilds when it needs
it, e.g. contact.skin.SkinList's record of its build). An array reached twice (the same object
under two names, e.g. the ANP volume that is the model's volume) is saved once and restored as
the same object. The run's own bookkeeping (next frame, writers' positions, the history file's
length) is saved with it under `run/`.

Format: a NumPy .npz archive (no pickle: `allow_pickle=False` on reading), one entry per leaf,
named `<path>|<tag>`, plus `__format__` and `__step__`. A checkpoint is written to a temporary
file and renamed (output/atomic.py), so a run killed at any moment leaves whole checkpoints
only; the last KEEP are kept.

Resume: the case is built again as for a fresh run (mesh, model, passes, Simulation), then
`restore` overwrites the state by walking the same attributes (in place when an array's shape
and dtype are unchanged, else by assignment). The steps after a resume are the same bits as
those of the uninterrupted run (tests/solver/test_checkpoint.py).
"""

from __future__ import annotations

import math
import re
from collections import deque
from pathlib import Path

import numpy as np

FORMAT = 1
KEEP = 2
DIR = "checkpoints"
_NAME = re.compile(r"^checkpoint_(\d{9})\.npz$")


class CheckpointError(Exception):
    """A checkpoint that cannot be read or does not fit the case."""


# --- walking the state -------------------------------------------------------------------------
def _is_ours(obj) -> bool:
    mod = type(obj).__module__ or ""
    return mod.startswith("impactsim.") and not mod.startswith("impactsim.case") \
        and hasattr(obj, "__dict__")


def _esc(name) -> str:
    return str(name).replace("%", "%25").replace("/", "%2F").replace("|", "%7C")


def _unesc(name: str) -> str:
    return name.replace("%7C", "|").replace("%2F", "/").replace("%25", "%")


_SCALARS = (bool, int, float, str, np.generic, type(None))


def _scalar_entry(v):
    if v is None:
        return "n", np.array(0)
    if isinstance(v, (bool, np.bool_)):
        return "b", np.array(bool(v))
    if isinstance(v, np.generic):
        return "g", np.array(v)
    if isinstance(v, int):
        return "i", np.array(v, dtype=np.int64)
    if isinstance(v, float):
        return "f", np.array(v, dtype=np.float64)
    return "s", np.array(v)


def _scalar_value(tag: str, a: np.ndarray):
    if tag == "n":
        return None
    if tag == "b":
        return bool(a)
    if tag == "g":
        return a[()]
    if tag == "i":
        return int(a)
    if tag == "f":
        return float(a)
    return str(a)


def collect(roots: dict[str, object]) -> tuple[dict[str, np.ndarray], list[str]]:
    """The state under `roots` as npz entries, and the paths of what was left out. The walk is
    breadth first, so an array or object reached twice is saved under its shallowest path (an
    attribute chain that a state built afresh has too) and its other places are aliases."""
    out: dict[str, np.ndarray] = {}
    skipped: list[str] = []
    primary: dict[int, str] = {}
    keep_alive = []
    queue = deque((root, name) for name, root in roots.items())
    while queue:
        v, path = queue.popleft()
        if isinstance(v, np.ndarray) or _is_ours(v):
            if id(v) in primary:
                out[f"{path}|alias"] = np.array(primary[id(v)])
                continue
            primary[id(v)] = path
            keep_alive.append(v)
        if isinstance(v, np.ndarray):
            if v.dtype.hasobject:
                skipped.append(f"{path} (object array)")
                out[f"{path}|skip"] = np.array(0)
            else:
                out[f"{path}|a"] = v
        elif isinstance(v, _SCALARS):
            tag, a = _scalar_entry(v)
            out[f"{path}|{tag}"] = a
        elif isinstance(v, dict):
            out[f"{path}|dict"] = np.array(0)
            for k, item in v.items():
                if not isinstance(k, (str, int)) or isinstance(k, bool):
                    skipped.append(f"{path} (key {k!r})")
                    continue
                queue.append((item, f"{path}/{'#' if isinstance(k, int) else ''}{_esc(k)}"))
        elif isinstance(v, (list, tuple, deque)):
            kind = {list: "list", tuple: "tuple", deque: "deque"}.get(type(v))
            if kind is None:  # a named tuple or a subclass: configuration
                skipped.append(f"{path} ({type(v).__name__})")
                out[f"{path}|skip"] = np.array(0)
                continue
            out[f"{path}|{kind}"] = np.array(len(v))
            for i, item in enumerate(v):
                queue.append((item, f"{path}/{i}"))
        elif _is_ours(v):
            out[f"{path}|obj"] = np.array(0)
            transient = getattr(type(v), "CHECKPOINT_TRANSIENT", ())
            for k, item in vars(v).items():
                if k in transient:  # rebuilt when needed: the fresh state's value stays
                    out[f"{path}/{_esc(k)}|skip"] = np.array(0)
                    continue
                queue.append((item, f"{path}/{_esc(k)}"))
        elif callable(v):
            out[f"{path}|skip"] = np.array(0)  # functions, dispatchers: code, rebuilt
        else:
            skipped.append(f"{path} ({type(v).__module__}.{type(v).__name__})")
            out[f"{path}|skip"] = np.array(0)  # the fresh state's value stays
    return out, skipped


def _tree(data) -> dict:
    """path -> (tag, key) of every entry."""
    tree = {}
    for key in data:
        if "|" in key:
            path, tag = key.rsplit("|", 1)
            tree[path] = (tag, key)
    return tree


def restore(roots: dict[str, object], data) -> None:
    """Overwrite the state under `roots` (built afresh from the case) with a checkpoint's.
    Two passes: the second resolves the aliases whose target came later in the first."""
    tree = _tree(data)
    children: dict[str, list[str]] = {}
    for path in tree:
        if "/" in path:
            parent, name = path.rsplit("/", 1)
            children.setdefault(parent, []).append(name)
    found: dict[str, object] = {}
    missing: set[str] = set()

    def fit(current, path: str):
        """The value at `path` in the checkpoint, reusing `current` where it fits."""
        tag, key = tree[path]
        if tag == "a":
            saved = data[key]
            if isinstance(current, np.ndarray) and current.shape == saved.shape and \
                    current.dtype == saved.dtype and current.flags.writeable:
                current[...] = saved
                val = current
            elif isinstance(found.get(path), np.ndarray) and found[path].shape == saved.shape:
                val = found[path]  # the second pass: the array made in the first
            else:
                val = np.array(saved)
            found[path] = val
            return val
        if tag == "alias":
            target = str(data[key])
            if target in found:
                missing.discard(path)
                return found[target]
            missing.add(path)
            return current
        if tag == "skip":
            return current  # configuration: the value built from the case stays
        if tag == "obj":
            if not _is_ours(current):
                raise CheckpointError(f"{path}: the checkpoint holds an object the state built "
                                      "from the case has not")
            found[path] = current
            for name in children.get(path, []):
                attr = _unesc(name)
                setattr(current, attr, fit(getattr(current, attr, None), f"{path}/{name}"))
            return current
        if tag == "dict":
            d = current if isinstance(current, dict) else {}
            names = children.get(path, [])
            keys = [int(n[1:]) if n.startswith("#") else _unesc(n) for n in names]
            for k, name in zip(keys, names):
                d[k] = fit(d.get(k), f"{path}/{name}")
            for k in [k for k in d if k not in set(keys)]:
                del d[k]  # entries the fresh state has and the checkpoint had not
            return d
        if tag in ("list", "tuple", "deque"):
            n = int(data[key])
            cur = list(current) if isinstance(current, (list, tuple, deque)) else []
            items = [fit(cur[i] if i < len(cur) else None, f"{path}/{i}") for i in range(n)]
            if tag == "list" and isinstance(current, list):
                current[:] = items
                return current
            if tag == "deque" and isinstance(current, deque):
                current.clear()
                current.extend(items)
                return current
            return {"list": list, "tuple": tuple, "deque": deque}[tag](items)
        if tag in ("n", "b", "g", "i", "f", "s"):
            return _scalar_value(tag, data[key])
        raise CheckpointError(f"unknown entry {key}")

    for _ in range(2):
        for name in list(roots):
            roots[name] = fit(roots[name], name)
    if missing:
        raise CheckpointError(f"aliases to parts the checkpoint does not hold: {sorted(missing)[:3]}")


# --- files -------------------------------------------------------------------------------------
def checkpoint_dir(out: Path) -> Path:
    return Path(out) / DIR


def write_checkpoint(sim, directory: Path, run_state: dict | None = None) -> Path:
    """Write the state of `sim` (a Simulation: its model, passes and buffers) and `run_state`
    (the run's own bookkeeping) to <directory>/checkpoints/checkpoint_<step>.npz, atomically;
    keep the last KEEP checkpoints. Returns the file."""
    from impactsim.output.atomic import replacing

    folder = checkpoint_dir(directory)
    folder.mkdir(parents=True, exist_ok=True)
    if run_state is None and callable(getattr(sim, "run_bookkeeping", None)):
        run_state = sim.run_bookkeeping()  # set by solver/run.py: writers' positions...
    entries, _ = collect({"sim": sim, "run": run_state or {}})
    entries["__format__"] = np.array(FORMAT)
    entries["__step__"] = np.array(sim.model.step)
    entries["__time__"] = np.array(sim.model.time)
    path = folder / f"checkpoint_{sim.model.step:09d}.npz"
    with replacing(path) as tmp:
        with open(tmp, "wb") as fh:
            np.savez(fh, **entries)
    for old in list_checkpoints(directory)[:-KEEP]:
        old.unlink(missing_ok=True)
    return path


def list_checkpoints(directory: Path) -> list[Path]:
    """The checkpoints of a run folder, oldest first."""
    folder = checkpoint_dir(directory)
    if not folder.is_dir():
        return []
    return sorted(p for p in folder.iterdir() if _NAME.match(p.name))


def read_checkpoint(path: Path) -> dict[str, np.ndarray]:
    try:
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except (OSError, ValueError, EOFError) as err:
        raise CheckpointError(f"{path}: cannot read the checkpoint: {err}") from None
    if int(data.get("__format__", -1)) != FORMAT:
        raise CheckpointError(f"{path}: checkpoint format {data.get('__format__')}, this "
                              f"impactsim reads format {FORMAT}")
    return data


def latest_checkpoint(directory: Path) -> Path:
    found = list_checkpoints(directory)
    if not found:
        raise CheckpointError(f"{directory}: no checkpoint to resume from (run with "
                              "[output] checkpoint_every to write them)")
    return found[-1]


def run_state(data: dict[str, np.ndarray]) -> dict:
    """The `run` part of a checkpoint as a dict."""
    holder = {"run": {}}
    restore(holder, {k: v for k, v in data.items() if k.startswith("run")})
    return holder["run"]


class Schedule:
    """When checkpoints are due: every N steps (an int) or every T seconds of simulated time
    (a float); 0 never."""

    def __init__(self, every: int | float, start_step: int = 0, start_time: float = 0.0):
        self.every = every
        self.by_steps = isinstance(every, int) and not isinstance(every, bool)
        self.next_time = (math.floor(start_time / every + 1e-9) + 1) * every \
            if not self.by_steps and every > 0 else math.inf

    @property
    def active(self) -> bool:
        return self.every > 0

    def due(self, step: int, time: float) -> bool:
        if not self.active:
            return False
        if self.by_steps:
            return step % self.every == 0
        if time >= self.next_time * (1 - 1e-12):
            while self.next_time <= time * (1 + 1e-12):
                self.next_time += self.every
            return True
        return False


# --- the run's side ----------------------------------------------------------------------------
def open_resume(out: Path, case_dict: dict) -> dict[str, np.ndarray]:
    """The last checkpoint of the run in `out`, after checking that `case_dict` (the resolved
    case given now) is the case that run ran (case.resolved.toml)."""
    import tomllib

    from impactsim.output.summary import _plain

    out = Path(out)
    resolved = out / "case.resolved.toml"
    if not resolved.is_file():
        raise CheckpointError(f"{out}: not a run folder (no case.resolved.toml) to resume")
    then = tomllib.loads(resolved.read_text())
    now = _plain(case_dict, "", float, drop_none=True)
    if then != now:
        diff = sorted(k for k in set(then) | set(now) if then.get(k) != now.get(k))
        raise CheckpointError(f"{out}: the case differs from the one that run ran (tables "
                              f"{', '.join(diff)}); resume with the same case and --set options")
    from impactsim.output.atomic import remove_stale_temporaries

    remove_stale_temporaries(out)  # what the interrupted run was writing when it was killed
    remove_stale_temporaries(checkpoint_dir(out))
    return read_checkpoint(latest_checkpoint(out))


def resume_into(sim, data: dict[str, np.ndarray]) -> dict:
    """Restore `sim` from a checkpoint; returns the run's bookkeeping saved with it."""
    restore({"sim": sim}, {k: v for k, v in data.items() if k.startswith("sim")})
    return run_state(data)
