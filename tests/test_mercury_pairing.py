"""The slow twin of the .fstat pairing agrees with itself: its in-turn fast path (oracle_lines_in_turn)
against its general pairing by a sort (oracle_one_listing_per_pair), the same kept lines whenever the fast
path answers and no answer whenever the general path finds an error. The twin is the reference of the C pass
(cg_fstat_contacts, tests/test_mercury_fstat_core.py, which runs both of its own paths against it: lines
in turn, shuffled and reversed), so a twin whose two paths disagreed would make that comparison worthless."""
import numpy as np
import pytest

from oracle import oracle_lines_in_turn as lines_in_turn
from oracle import oracle_one_listing_per_pair

RTOL = 1e-8


def fstat_lines(rng, n=40, pairs=60, walls=10, shuffle_pairs=False):
    """Pair lines written in turn (both sides on consecutive pair lines, either side first), walls between."""
    keys = rng.choice(n * n, size=pairs, replace=False)
    a, b = keys // n, keys % n
    ok = a != b
    _, once = np.unique(np.minimum(a, b)[ok] * n + np.maximum(a, b)[ok], return_index=True)   # each pair once
    a, b = a[ok][np.sort(once)], b[ok][np.sort(once)]
    if not shuffle_pairs:
        order = np.lexsort((np.maximum(a, b), np.minimum(a, b)))
        a, b = a[order], b[order]
    f = rng.normal(size=(len(a), 3))
    c = rng.normal(size=(len(a), 3))
    rows = []
    for p, q, force, point in zip(a, b, f, c):
        sides = [(p, q, force), (q, p, -force)]
        if rng.random() < 0.5:
            sides.reverse()
        rows += [(s, t, g, point) for s, t, g in sides]
        if rng.random() < walls / max(len(a), 1):
            rows.append((int(rng.integers(n)), -1 - int(rng.integers(3)), rng.normal(size=3), rng.normal(size=3)))
    i = np.array([r[0] for r in rows], np.int64)
    j = np.array([r[1] for r in rows], np.int64)
    return i, j, np.array([r[2] for r in rows]), np.array([r[3] for r in rows]), n


def both(i, j, force, point, n, fixed=None):
    radii = np.full(n, 0.5)
    fixed = np.zeros(n, bool) if fixed is None else fixed
    want = oracle_one_listing_per_pair(i, j, force, point, radii, fixed, RTOL)
    scale = float(np.max(np.linalg.norm(force, axis=1))) if len(force) else 0.0
    lines = np.flatnonzero(j >= 0)
    got = lines_in_turn(i, j, force, point, lines, RTOL * max(scale, 1e-300), RTOL * 2.0 * float(radii.max()))
    if got is not None:
        keep = np.zeros(i.shape, bool)
        keep[got] = True
        assert isinstance(want, np.ndarray), want
        np.testing.assert_array_equal(keep, want)
    return got, want


@pytest.mark.parametrize("seed", range(40))
@pytest.mark.parametrize("shuffle_pairs", [False, True])
@pytest.mark.parametrize("walls", [10, 0])
def test_pairs_in_turn_keep_the_oracles_lines(seed, shuffle_pairs, walls):
    i, j, force, point, n = fstat_lines(np.random.default_rng(seed), walls=walls, shuffle_pairs=shuffle_pairs)
    assert walls or np.all(j >= 0)
    got, want = both(i, j, force, point, n)
    assert got is not None and isinstance(want, np.ndarray)


@pytest.mark.parametrize("seed", range(40))
@pytest.mark.parametrize("damage", ["duplicate", "force", "point", "drop", "swap", "one side twice", "other particle", "other partner"])
def test_damaged_pair_lines_leave_the_fast_path(seed, damage):
    rng = np.random.default_rng(seed)
    i, j, force, point, n = fstat_lines(rng, walls=10 * (seed % 3 > 0), shuffle_pairs=bool(seed % 2))
    pair = np.flatnonzero(j >= 0)
    k = int(pair[2 * rng.integers(len(pair) // 2)])     # the first line of a pair
    if damage == "duplicate":     # the pair listed again, in turn, later (or earlier) in the file
        where = int(rng.integers(len(i) + 1))
        while where > 0 and where < len(i) and j[where - 1] >= 0 and np.sum(j[:where] >= 0) % 2:
            where += 1
        take = [k, k + 1]
        i, j = np.insert(i, where, i[take]), np.insert(j, where, j[take])
        force, point = np.insert(force, where, force[take], axis=0), np.insert(point, where, point[take], axis=0)
    elif damage == "force":
        force[k] *= 1.0 + 1e-6
    elif damage == "point":
        point[k, 0] += 1e-6
    elif damage == "drop":
        keep = np.ones(len(i), bool)
        keep[k] = False
        i, j, force, point = i[keep], j[keep], force[keep], point[keep]
    elif damage == "swap":     # two lines of different pairs exchanged: no longer in turn
        other = int(pair[(np.searchsorted(pair, k) + 3) % len(pair)])
        for arr in (i, j, force, point):
            arr[[k, other]] = arr[[other, k]]
    elif damage == "one side twice":    # the second line repeats the first side
        second = int(pair[np.searchsorted(pair, k) + 1])
        i[second], j[second], force[second] = i[k], j[k], -force[k]
    else:    # the second line names another particle: (p, q) then (r, p) or (q, r)
        second = int(pair[np.searchsorted(pair, k) + 1])
        column = i if damage == "other particle" else j
        column[second] = next(r for r in range(n) if r not in (i[k], j[k]))
    got, want = both(i, j, force, point, n)
    if not isinstance(want, np.ndarray):
        assert got is None, want


def test_a_fixed_particles_pair_listed_once_is_the_general_paths():
    i, j, force, point, n = fstat_lines(np.random.default_rng(7))
    k = int(np.flatnonzero(j >= 0)[0])
    fixed = np.zeros(n, bool)
    fixed[i[k]] = True
    keep = np.ones(len(i), bool)
    keep[k + 1] = False
    got, want = both(i[keep], j[keep], force[keep], point[keep], n, fixed)
    assert got is None and isinstance(want, np.ndarray) and want.sum() == (np.sum(j >= 0) - 2) // 2 + 1
