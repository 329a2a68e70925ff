"""The catalogue of primary sums (cgbound.primaries.PRIMARIES) is the one place a primary is described."""
import importlib.util
from pathlib import Path

import numpy as np
import pytest

import cgbound as cg
from cgbound.fields import COUPLE_STRESS_FORMS, FIELDS, needed_primaries
from cgbound.primaries import CONTACT_PRIMARIES, PRIMARIES, SOURCES, compute_primaries, reference_velocity
from cgbound.grid import Grid

from helpers import random_snapshot



def test_every_field_names_only_catalogued_primaries():
    for name, (rank, primaries) in FIELDS.items():
        for primary in primaries:
            assert primary in PRIMARIES, f"field {name!r} needs {primary!r}, which the catalogue does not describe"


def test_every_primary_is_needed_by_some_field():
    # in one of the couple stress forms (the branch-line one replaces three primaries)
    used = set().union(*(needed_primaries(tuple(FIELDS), form) for form in COUPLE_STRESS_FORMS))
    assert set(PRIMARIES) == used


def test_catalogue_entries_are_complete():
    for name, p in PRIMARIES.items():
        assert p.name == name
        assert p.source in SOURCES
        assert p.rank in (0, 1, 2)
        assert p.symbol and p.description and p.twin.startswith("oracle_")
    assert CONTACT_PRIMARIES == {"sb", "sw", "t", "sx", "fb", "fw", "couple", "pair_torque", "wall_couple",
                                 "couple_bl", "pair_torque_bl", "wall_couple_bl"}


def test_twins_exist_in_the_oracle():
    path = Path(__file__).with_name("oracle.py")
    if not path.exists():
        pytest.skip("tests/oracle.py (the renamed reference twins) is not in this tree yet")
    spec = importlib.util.spec_from_file_location("oracle_for_catalogue", path)
    oracle = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(oracle)
    for p in PRIMARIES.values():
        assert callable(getattr(oracle, p.twin, None)), f"{p.name}: no {p.twin} in tests/oracle.py"


@pytest.mark.parametrize("form", COUPLE_STRESS_FORMS)
@pytest.mark.parametrize("fields", [tuple(FIELDS)], ids=["all"])
def test_computed_primaries_have_the_catalogued_rank(fields, form):
    snap = random_snapshot(7, dim=3)
    snap = cg.Snapshot(snap.positions, snap.velocities, snap.masses, box=snap.box, contacts=snap.contacts,
                       fixed=snap.fixed, body_force=[0.0, 0.0, -1.0], radii=np.full(snap.n_particles, 0.5),
                       angular_velocities=np.random.default_rng(7).normal(size=(snap.n_particles, 3)))
    grid = Grid(snap.box, (3, 4, 5))
    needed = needed_primaries(fields, form)
    out = compute_primaries(snap, grid, cg.Lucy(1.5), needed, reference_velocity(snap))
    assert set(out) == needed
    for name, value in out.items():
        assert value.shape == (grid.size,) + (3,) * PRIMARIES[name].rank, name
