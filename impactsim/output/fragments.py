"""fragments.png: the fragment-size histogram of a run (summary.json ``fragments``,
impactsim.fracture.fragments), written when ``[output] fragment_histogram = true``."""

from __future__ import annotations

from pathlib import Path


def write_fragment_histogram(path: Path, fragments: dict, title: str = "") -> bool:
    """Number of fragments and their mass per logarithmic mass bin; False when there is
    nothing to draw."""
    h = fragments.get("size_histogram")
    if not h:
        return False
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from impactsim.output.atomic import replacing

    edges = np.asarray(h["mass_edges"]) * 1e6  # mg
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(9, 3.6))
    for ax, val, label in ((a1, h["count"], "fragments"), (a2, np.asarray(h["mass"]) * 1e6,
                                                           "mass in the bin [mg]")):
        ax.stairs(val, edges, fill=True, alpha=0.7)
        ax.set_xscale("log")
        ax.set_xlabel("fragment mass [mg]")
        ax.set_ylabel(label)
    a1.set_yscale("log")
    fig.suptitle(f"{title}: {fragments['count']} fragments ({fragments['mesh_pieces']} mesh "
                 f"pieces, {fragments['particles']} particles)")
    fig.tight_layout()
    with replacing(path) as tmp:
        fig.savefig(tmp, format="png", dpi=100)
    plt.close(fig)
    return True
