"""Snapshot.split_contacts: the shortcut for snapshots whose contacts are all bulk agrees with the general path."""
import numpy as np
import pytest

import cgbound as cg
from helpers import random_snapshot


def with_idle_fixed_particle(snap):
    """The same snapshot plus one fixed particle without contacts (forces split_contacts' general path)."""
    pos = np.vstack([snap.positions, snap.box.lower])
    vel = np.vstack([snap.velocities, np.zeros(snap.dim)])
    fixed = np.append(snap.fixed, True)
    return cg.Snapshot(pos, vel, np.append(snap.masses, 1.0), box=snap.box, contacts=snap.contacts, fixed=fixed)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("periodic", [False, True])
def test_all_bulk_shortcut_matches_general_path(dim, periodic):
    snap = random_snapshot(7, dim=dim, n=30, n_fixed=0, n_bulk=25, n_fixed_contacts=0, n_wall=0,
                           periodic=(periodic,) * dim, outside=periodic)
    assert not snap.fixed.any() and np.all(snap.contacts.j >= 0)
    fast_bulk, fast_boundary = snap.split_contacts()
    slow_bulk, slow_boundary = with_idle_fixed_particle(snap).split_contacts()
    for key in ("i", "j", "force", "branch"):
        assert fast_bulk[key].dtype == slow_bulk[key].dtype
        assert np.array_equal(fast_bulk[key], slow_bulk[key]), key
    for key in ("i", "force", "branch", "point"):
        assert fast_boundary[key].shape == slow_boundary[key].shape == (0,) * fast_boundary[key].ndim \
            or fast_boundary[key].shape == slow_boundary[key].shape, key
        assert fast_boundary[key].dtype == slow_boundary[key].dtype, key


def test_all_bulk_shortcut_cannot_write_into_the_contacts():
    snap = random_snapshot(3, dim=3, n_fixed=0, n_fixed_contacts=0, n_wall=0)
    bulk, _ = snap.split_contacts()
    before = snap.contacts.force.copy()
    with pytest.raises(ValueError, match="read-only"):
        bulk["force"][0, 0] = 99.0
    assert np.array_equal(snap.contacts.force, before)
