"""Studies over many runs: sweeps (sweep.py), ballistic limits (ballistic.py), both on Dask
(cluster.py: a LocalCluster of worker processes, an existing scheduler, or this process)."""
