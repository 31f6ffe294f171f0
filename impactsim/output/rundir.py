"""The output folder of a run: refuse to mix a new run's frames with an earlier run's.

ParaView reads `series.pvd`, but a folder also holding frame files of an earlier, longer run
invites mistakes (a file browser, a glob over frame_*.vtu), and an earlier run's checkpoints
would resume the wrong run. `prepare(out, overwrite)` creates the folder; when it holds an
earlier run's outputs it raises OutputExists unless `overwrite`, which removes them first (the
frames, the collections, history.csv, summary.json, the checkpoints; render/ and other files of
the user stay).
"""

from __future__ import annotations

import shutil
from pathlib import Path

RUN_FILES = ("series.pvd", "particles.pvd", "history.csv", "summary.json", "case.resolved.toml")
FRAME_GLOBS = ("frame_*.vtu", "particles_*.vtu")


class OutputExists(Exception):
    """The folder holds an earlier run's outputs."""


def earlier_run(out: Path) -> list[Path]:
    """The files of an earlier run in `out`."""
    if not out.is_dir():
        return []
    found = [out / f for f in RUN_FILES if (out / f).exists()]
    for pattern in FRAME_GLOBS:
        found += sorted(out.glob(pattern))
    if (out / "checkpoints").is_dir():
        found.append(out / "checkpoints")
    return found


def prepare(out: Path, overwrite: bool) -> None:
    """Create `out`; clear an earlier run's outputs if `overwrite`, else refuse (docstring)."""
    old = earlier_run(out)
    frames = [p for p in old if p.suffix in (".vtu", ".pvd")]
    if frames and not overwrite:
        raise OutputExists(f"{out} holds the frames of an earlier run ({len(frames)} files); "
                           "give --overwrite to replace them, or another folder with -o")
    for p in old:
        if p.is_dir():
            shutil.rmtree(p)
        else:
            p.unlink(missing_ok=True)
    if old:
        from impactsim.output.atomic import remove_stale_temporaries

        remove_stale_temporaries(out)
    out.mkdir(parents=True, exist_ok=True)
