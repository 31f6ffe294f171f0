"""`impactsim plot DIR`: the history of a run as one PNG of four panels (matplotlib, Agg).

1. energy terms [J]: kinetic, internal, viscous, contact dissipated, eroded, particles, external
   work, and their balance total_energy (what should stay constant);
2. contact force [N]: the normal contact impulse of a step over its step (contact_impulse / dt)
   and the walls' normal force, whichever the run has;
3. body velocities [m/s]: the z (or the largest-changing) component of each body's mean
   velocity, from the per-body columns <body>.velocity_x|y|z; without them the total momentum;
4. particle count, and the damaged / fractured / eroded element counts.
A panel whose columns the run does not have says so. History files with or without units in
their headers are read (results.read_history).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from impactsim.output.atomic import replacing


class PlotError(Exception):
    """The history cannot be plotted; the message says why."""


ENERGY_TERMS = ["kinetic_energy", "internal_energy", "viscous_energy", "contact_dissipated",
                "eroded_energy", "particle_energy", "external_work"]


def plot_history(run_dir: str | os.PathLike, out: str | os.PathLike | None = None,
                 size: tuple[float, float] = (11.0, 8.0), dpi: int = 110) -> Path:
    """Write the four panels of the module docstring to `out` (default run_dir/history.png)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from impactsim.results import read_history

    run_dir = Path(run_dir)
    path = run_dir / "history.csv"
    if not path.is_file():
        raise PlotError(f"{path} not found: {run_dir} is not the output folder of a run")
    try:
        h, _ = read_history(path)
    except Exception as err:  # pandas raises several types for a broken file
        raise PlotError(f"{path}: cannot read: {err}") from err
    if len(h) == 0 or "time" not in h:
        raise PlotError(f"{path}: no rows")
    t = h["time"].to_numpy() * 1e6
    fig, axes = plt.subplots(2, 2, figsize=size, dpi=dpi, sharex=True)
    ax = axes[0, 0]
    for k in ENERGY_TERMS:
        if k in h and np.any(h[k].to_numpy() != 0):
            ax.plot(t, h[k], label=k.replace("_", " "))
    if "total_energy" in h:
        e = h["total_energy"].to_numpy()
        ax.plot(t, e, "k-", lw=2, label="total (balance)")
        if e[0]:
            ax.set_title(f"Energy: balance error {100 * (e[-1] - e[0]) / abs(e[0]):+.2f} % at the end",
                         fontsize=10)
    ax.set_ylabel("energy [J]")
    ax.legend(fontsize=7)
    ax = axes[0, 1]
    shown = False
    if "contact_impulse" in h and "dt" in h:
        dt = h["dt"].to_numpy()
        f = np.divide(h["contact_impulse"].to_numpy(), dt, out=np.zeros(len(dt)), where=dt > 0)
        ax.plot(t, f, label="contact (impulse / dt)")
        shown = True
    if "wall_force" in h:
        ax.plot(t, h["wall_force"], label="walls")
        shown = True
    ax.set_ylabel("force [N]")
    ax.set_title("Contact force" if shown else "Contact force: no contact or wall in this run",
                 fontsize=10)
    if shown:
        ax.legend(fontsize=7)
    ax = axes[1, 0]
    vel = [c for c in h.columns if c.rsplit(".", 1)[-1] in ("velocity_x", "velocity_y",
                                                             "velocity_z")]
    if vel:
        bodies = sorted({c.rsplit(".", 1)[0] for c in vel}, key=[c.rsplit(".", 1)[0]
                                                                   for c in vel].index)
        for b in bodies:
            comps = [f"{b}.velocity_{c}" for c in "xyz" if f"{b}.velocity_{c}" in h]
            k = max(comps, key=lambda c: np.ptp(h[c].to_numpy()) + abs(h[c].iloc[0]))
            ax.plot(t, h[k], label=k)
        ax.set_title("Body mean velocities (the component that changes most)", fontsize=10)
        ax.set_ylabel("velocity [m/s]")
    else:
        for c in ("momentum_x", "momentum_y", "momentum_z"):
            if c in h:
                ax.plot(t, h[c], label=c)
        ax.set_title("Momentum (no per-body velocity columns in this run)", fontsize=10)
        ax.set_ylabel("momentum [kg m/s]")
    ax.legend(fontsize=7)
    ax.set_xlabel("time [µs]")
    ax = axes[1, 1]
    counts = [c for c in ("particles", "damaged", "fractured", "eroded_elements") if c in h]
    for c in counts:
        ax.plot(t, h[c], label=c.replace("_", " "))
    ax.set_title("Particles and failed elements" if counts else "No fracture in this run",
                 fontsize=10)
    ax.set_ylabel("count")
    ax.set_xlabel("time [µs]")
    if counts:
        ax.legend(fontsize=7)
    for a in axes.ravel():
        a.grid(alpha=0.3)
    fig.suptitle(f"{run_dir.name}: history", fontsize=11)
    fig.tight_layout()
    target = Path(out) if out is not None else run_dir / "history.png"
    target.parent.mkdir(parents=True, exist_ok=True)
    with replacing(target) as tmp:
        fig.savefig(tmp)
    plt.close(fig)
    return target
