"""Derived results of a run for history.csv and summary.json, from the model's arrays.

- `body_velocities`: the mass-weighted mean velocity of each body (history columns
  <body>.velocity_x|y|z [m/s]).
- `wall_measures`: for a scene with rigid walls, per body that touched a wall (a node within a
  mean edge length of the wall's plane at the end): its length along the wall's normal at the
  end (`final_length` [m], the Taylor test's L1) and initially (`initial_length`), and the
  diameter of its foot (`foot_diameter` [m]: twice the largest distance, in the wall's plane,
  of the body's nodes within that reach of the wall from their centroid).
"""

from __future__ import annotations

import numpy as np


def body_velocities(model) -> dict[str, float]:
    out = {}
    for b, name in enumerate(model.body_names):
        sl = slice(model.node_start[b], model.node_start[b + 1])
        m = model.mass[sl]
        mt = float(m.sum())
        v = (m @ model.v[sl]) / mt if mt > 0 else np.zeros(3)
        out.update({f"{name}.velocity_x": float(v[0]), f"{name}.velocity_y": float(v[1]),
                    f"{name}.velocity_z": float(v[2])})
    return out


def velocity_columns(model) -> list[str]:
    return [f"{n}.velocity_{c}" for n in model.body_names for c in "xyz"]


def wall_measures(model) -> dict[str, dict]:
    out: dict[str, dict] = {}
    if not len(model.walls):
        return out
    for b, name in enumerate(model.body_names):
        ns = slice(model.node_start[b], model.node_start[b + 1])
        es = slice(model.elem_start[b], model.elem_start[b + 1])
        x, x0 = model.x[ns], model.x0[ns]
        conn = model.conn[es]
        for blk in getattr(model, "blocks", ()):  # a hex body's elements are in a block
            if conn.shape[0] == 0:
                conn = blk.conn[blk.body_start[b]:blk.body_start[b + 1]]
        if conn.shape[0] == 0 or not np.isfinite(x).all():
            continue  # no elements, or a state that stopped non-finite
        conn = conn - model.node_start[b]
        e = x0[conn[:, 1]] - x0[conn[:, 0]]
        reach = 0.1 * float(np.sqrt((e * e).sum(axis=1)).mean())
        for w in model.walls:
            p, n = w[:3], w[3:6]
            d = (x - p) @ n
            foot = d <= d.min() + reach
            if d.min() > 10.0 * reach:
                continue  # not at this wall at the end
            d0 = (x0 - p) @ n
            q = x[foot] - np.outer(d[foot], n)  # foot nodes in the wall's plane
            c = q.mean(axis=0)
            out[name] = {"final_length": float(np.ptp(d)), "initial_length": float(np.ptp(d0)),
                         "foot_diameter": 2.0 * float(np.sqrt(((q - c) ** 2).sum(axis=1)).max())}
            break
    return out
