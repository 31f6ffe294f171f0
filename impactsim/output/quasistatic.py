"""Files of a quasistatic run: a VTU series over the load steps (all bodies in one mesh per
step), the convergence history (CSV and a PNG plot), summary.json and the resolved case.

Every file goes through ``atomic``: a killed run leaves complete files of the finished steps.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from impactsim.output.atomic import replacing, write_text
from impactsim.output.series import SeriesWriter
from impactsim.output.summary import write_resolved_case, write_summary

LOG_COLUMNS = ("phase", "step", "iteration", "gap_residual", "pressure_residual",
               "motion_residual", "relaxation",
               "active", "active_changed", "change")


def von_mises(s: np.ndarray) -> np.ndarray:
    """von Mises stress of (6, n) stresses xx yy zz yz xz xy."""
    xx, yy, zz, yz, xz, xy = s
    return np.sqrt(0.5 * ((xx - yy) ** 2 + (yy - zz) ** 2 + (zz - xx) ** 2)
                   + 3 * (yz ** 2 + xz ** 2 + xy ** 2))


class QuasistaticWriter:
    def __init__(self, directory: Path):
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.series = SeriesWriter(self.directory, prefix="step", pvd_name="series.pvd")

    def write_step(self, time: float, bodies, fields: dict, contact: dict) -> Path:
        """bodies: the BodyModels; fields: body index -> {u, T, stress}; contact: body index ->
        (vertex indices, pressure, gap) on its kinematic sides."""
        pts, cells, data = [], [], {k: [] for k in ("displacement", "temperature", "stress",
                                                    "von_mises", "contact_pressure", "gap",
                                                    "body")}
        offset = 0
        for i, b in enumerate(bodies):
            nv = b.points.shape[1]
            f = fields[i]
            pts.append(b.points.T)
            cells.append(b.tets.T + offset)
            u = f["u"].reshape(-1, 3)[:nv]
            data["displacement"].append(u)
            data["temperature"].append(f["T"][:nv])
            s = f["stress"]
            data["stress"].append(s[[0, 1, 2, 5, 3, 4]].T)  # Voigt xx yy zz xy yz zx
            data["von_mises"].append(von_mises(s))
            p = np.zeros(nv)
            g = np.full(nv, np.nan)
            for idx, pv, gv in contact.get(i, []):
                keep = idx < nv
                p[idx[keep]] = pv[keep]
                g[idx[keep]] = gv[keep]
            data["contact_pressure"].append(p)
            data["gap"].append(g)
            data["body"].append(np.full(nv, i, dtype=np.int32))
            offset += nv
        return self.series.write(time, np.concatenate(pts), np.concatenate(cells),
                                 point_data={k: np.concatenate(v) for k, v in data.items()})

    def write_log(self, log: list[dict]) -> None:
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=LOG_COLUMNS, extrasaction="ignore")
        w.writeheader()
        for row in log:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in row.items()})
        write_text(self.directory / "convergence.csv", buf.getvalue())

    def plot_log(self, log: list[dict]) -> None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        mech = [r for r in log if r.get("phase") == "mechanics"]
        if not mech:
            return
        fig, ax = plt.subplots(figsize=(7, 4))
        x = np.arange(1, len(mech) + 1)
        for key, label in (("gap_residual", "gap mismatch"),
                           ("pressure_residual", "pressure mismatch")):
            y = np.array([max(float(r[key]), 1e-16) for r in mech])
            ax.semilogy(x, y, label=label)
        steps = [r["step"] for r in mech]
        for k in range(1, len(steps)):
            if steps[k] != steps[k - 1]:
                ax.axvline(k + 0.5, color="0.8", lw=0.8)
        ax.set_xlabel("Schwarz iteration (all load steps)")
        ax.set_ylabel("relative mismatch")
        ax.legend()
        ax.grid(True, which="both", alpha=0.3)
        fig.tight_layout()
        with replacing(self.directory / "convergence.png") as tmp:
            fig.savefig(tmp, dpi=100)
        plt.close(fig)

    def write_summary(self, summary: dict) -> None:
        write_summary(self.directory / "summary.json", summary)

    def write_case(self, case_dict: dict) -> None:
        write_resolved_case(self.directory / "case.resolved.toml", case_dict)

    def close(self) -> None:
        self.series.close()
