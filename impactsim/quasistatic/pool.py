"""Where the bodies live: in this process, or on the workers of a Dask distributed cluster.

Both pools hold ``BodyGroup``s and forward one call per group and iteration; the Dask pool puts
one group per worker as an actor, so each body's factorisation stays in its worker's memory
between iterations and only interface values travel. The bodies are split into contiguous
groups of about equal element counts. Each body's solve depends only on its own inputs, so the
results are the same whatever the number of workers (the client combines them in body order).
"""

from __future__ import annotations

import pickle

import numpy as np

from impactsim.quasistatic.body import BodyGroup, BodySpec


BODY_OVERHEAD = 125  # tet-equivalents per body: the fixed cost of a body's solve per iteration


def partition(specs: list[BodySpec], groups: int) -> list[list[BodySpec]]:
    """Contiguous groups of about equal cost: elements plus a fixed cost per body. By elements
    alone the 50-pellet stack went [49 pellets, the tube] onto 2 workers, and the pellets'
    side did nearly all the work. The fixed cost, measured per body over a whole run of the
    50-pellet stack in process (session 10: heat, factorisations and 145 Schwarz solves): a
    pellet (214 tets) 0.55 s, the tube (10,942 tets, refactorised with its Robin springs)
    17.9 s, i.e. 1.6 ms per tet and 0.2 s (125 tets) per body; the 2000 of session 9 (from
    the pellets' mechanics solves alone) put the tube with about 157 of 349 pellets and gave its
    worker twice the other's CPU time."""
    cost = np.array([s.model.tets.shape[1] * (4 if s.model.order == 2 else 1) + BODY_OVERHEAD
                     for s in specs], dtype=float)
    groups = max(1, min(groups, len(specs)))
    edges = np.searchsorted(np.cumsum(cost), np.linspace(0, cost.sum(), groups + 1)[1:-1])
    out, start = [], 0
    for e in list(edges) + [len(specs)]:
        e = max(int(e), start + 1) if start < len(specs) else start
        out.append(specs[start:e])
        start = e
    return [g for g in out if g]


class LocalPool:
    """All bodies in this process (no Dask): tests, small cases, ``--workers 0``."""

    workers = 0

    def __init__(self, specs: list[BodySpec]):
        self.groups = [BodyGroup(specs)]

    def call(self, method: str, *args, per_body: dict | None = None) -> dict:
        out = {}
        for g in self.groups:
            a = ((_subset(per_body, g.bodies),) if per_body is not None else ()) + args
            out.update(getattr(g, method)(*a))
        return out

    def close(self) -> None:
        pass


class DaskPool:
    """One BodyGroup actor per worker of a Dask cluster: a LocalCluster of `workers` processes
    (one thread each) started here, or the cluster of the scheduler at `address`."""

    def __init__(self, specs: list[BodySpec], workers: int = 2, address: str | None = None):
        from distributed import Client, LocalCluster

        self.cluster = None
        if address:
            self.client = Client(address)
        else:
            self.cluster = LocalCluster(n_workers=workers, threads_per_worker=1,
                                        processes=True, dashboard_address=None)
            self.client = Client(self.cluster)
        names = list(self.client.scheduler_info()["workers"])
        self.workers = len(names)
        parts = partition(specs, len(names))
        futures = [self.client.submit(PickledGroup, part, actor=True, workers=[w], pure=False)
                   for part, w in zip(parts, names)]
        self.actors = [f.result() for f in futures]
        self.members = [[s.index for s in part] for part in parts]

    def call(self, method: str, *args, per_body: dict | None = None) -> dict:
        futures = []
        for actor, members in zip(self.actors, self.members):
            a = (({i: per_body[i] for i in members if i in per_body},)
                 if per_body is not None else ()) + args
            futures.append(actor.call(method, _dumps(a)))
        out = {}
        for f in futures:
            out.update(pickle.loads(f.result()))
        return out

    def close(self) -> None:
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()


def _dumps(obj) -> bytes:
    return pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)


class PickledGroup:
    """A BodyGroup behind one bytes object each way per call. Sent as they are, an
    iteration's dicts of a few thousand small arrays became as many frames of Dask's protocol:
    the client's communication threads then took twice its main thread's CPU time (100
    pellets, 2 workers, 40 iterations: 3.1 s process CPU, 1.1 s of it the main thread);
    pickled in band (a single frame) the same data costs a few milliseconds."""

    def __init__(self, specs: list[BodySpec]):
        self.group = BodyGroup(specs)

    def call(self, method: str, blob: bytes) -> bytes:
        return _dumps(getattr(self.group, method)(*pickle.loads(blob)))


def _subset(per_body: dict, bodies: dict) -> dict:
    return {i: per_body[i] for i in bodies if i in per_body}


def make_pool(specs: list[BodySpec], workers: int = 0, address: str | None = None):
    if address or workers > 0:
        return DaskPool(specs, workers or 1, address)
    return LocalPool(specs)
