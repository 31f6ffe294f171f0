"""Everything a run writes, each file replaced atomically so a killed run loses no finished output.

- atomic:   `replacing(path)`, `write_bytes`, `write_text`: temporary file, fsync, os.replace
- series:   `SeriesWriter`: numbered VTU frames (mesh or particles) and their .pvd collection
- history:  `HistoryWriter`: history.csv, whole lines only, full float precision
- summary:  `write_summary` (summary.json), `write_resolved_case` (case.resolved.toml)
- progress: `Progress`: terminal bar or sparse log lines
- render:   `render_series`: off-screen PNGs of a finished run (pyvista, imported when called)
"""

from impactsim.output.atomic import replacing, write_bytes, write_text
from impactsim.output.history import HistoryWriter
from impactsim.output.progress import Progress
from impactsim.output.render import RenderError, render_series
from impactsim.output.series import SeriesWriter
from impactsim.output.summary import write_resolved_case, write_summary

__all__ = [
    "HistoryWriter",
    "Progress",
    "RenderError",
    "SeriesWriter",
    "render_series",
    "replacing",
    "write_bytes",
    "write_resolved_case",
    "write_summary",
    "write_text",
]
