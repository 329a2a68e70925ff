"""The paper-reproduction wing: what reproduces Weinhart et al. (2012), above the library.

:mod:`~cgbound.paper.scenes` (the paper's simulations, run with LAMMPS), :mod:`~cgbound.paper.profiles`
(Fig. 3's depth profiles and eq. 27), :mod:`~cgbound.paper.datasets` (the shipped data) and
:mod:`~cgbound.paper.blobs` (Fig. 1's check). ``import cgbound`` does not import it.
"""
