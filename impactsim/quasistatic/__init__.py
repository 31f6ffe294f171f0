"""Quasi-static thermoelastic contact of many bodies: the alternating Schwarz method of [G15].

Each body is an independent finite-element problem (scikit-fem assembly, one scipy sparse LU
per body, reused across iterations); the bodies are coupled only through their contact
interfaces, by a Dirichlet-Neumann (kinematic / force) alternation with relaxation (ALGORITHMS.md
5 and 7.3). Modules, from the bottom up:

- ``model``: plain data of a problem (materials, bodies, boundary conditions, interfaces);
- ``geometry``: meshes of the primitives (gmsh) and facet selectors;
- ``heat``, ``elastic``: the per-body solvers (factorised once);
- ``matching``: closest points on triangulated surfaces, contact detection;
- ``coupling``: the interface operators (kinematic rows, force transfer, heat exchange);
- ``pool``: where the body solvers live (in process, or Dask actors on workers);
- ``schwarz``: the iteration; ``monolithic``: all bodies in one system (the check);
- ``run``: a case from start to outputs (the only module that writes files, via ``output``).
"""
