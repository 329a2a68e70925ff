"""The readers' fast paths against plain references: the LAMMPS contacts' atom positions (consecutive IDs
by subtraction, others by a search) against a dict of the IDs."""
import numpy as np
import pytest

from cgbound.readers.lammps import contact_indices

BIG = np.iinfo(np.int64).max


def positions_by_dict(ids, id1, id2):
    """Reference: the position of each ID in a dict; None where an ID is absent."""
    where = {int(v): k for k, v in enumerate(ids)}
    out = [(where.get(int(a)), where.get(int(b))) for a, b in zip(id1, id2)]
    bad = [k for k, (a, b) in enumerate(out) if a is None or b is None]
    return out, bad


ID_SETS = {
    "1..N": np.arange(1, 101, dtype=np.int64),
    "0..N-1": np.arange(0, 100, dtype=np.int64),
    "negative, consecutive": np.arange(-50, 50, dtype=np.int64),
    "near the int64 top": BIG - np.arange(99, -1, -1, dtype=np.int64),
    "near the int64 bottom": -BIG - 1 + np.arange(100, dtype=np.int64),
    "with gaps": np.sort(np.random.default_rng(1).choice(10 ** 6, 100, replace=False)).astype(np.int64),
    "one gap": np.r_[np.arange(1, 50), np.arange(51, 102)].astype(np.int64),
    "one atom": np.array([7], np.int64),
}


@pytest.mark.parametrize("name", sorted(ID_SETS))
@pytest.mark.parametrize("absent", [False, True])
def test_contact_indices_match_a_dict_of_the_ids(name, absent):
    ids = ID_SETS[name]
    rng = np.random.default_rng(len(name))
    id1, id2 = rng.choice(ids, 500), rng.choice(ids, 500)
    if absent:   # IDs just outside, far outside (where ID - first wraps around in int64) and in a gap
        strangers = [int(ids[0]) - 1, int(ids[-1]) + 1, -BIG - 1, BIG, int(ids[0]) + (1 if ids.size > 1 else 0)]
        strangers = [v for v in strangers if -BIG - 1 <= v <= BIG and v not in set(ids.tolist())]
        k = rng.choice(500, len(strangers), replace=False)
        id2[k] = strangers
    expected, bad = positions_by_dict(ids, id1, id2)
    if bad:
        k = bad[0]
        with pytest.raises(ValueError, match=rf"dump\.local: contact between atom IDs {id1[k]} and {id2[k]} at "
                                             rf"timestep 40: an ID is not in the atoms dump"):
            contact_indices(ids, id1, id2, "dump.local", 40)
        return
    assert not absent or name == "one atom"
    i, j = contact_indices(ids, id1, id2, "dump.local", 40)
    assert i.dtype == j.dtype == np.int64
    np.testing.assert_array_equal(i, [a for a, _ in expected])
    np.testing.assert_array_equal(j, [b for _, b in expected])


def test_contact_indices_of_no_atoms_are_an_error():
    with pytest.raises(ValueError, match="contact between atom IDs 1 and 2"):
        contact_indices(np.zeros(0, np.int64), np.array([1]), np.array([2]), "p", 0)
