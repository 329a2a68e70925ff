"""Where a field's weight sits: centroids of the blobs of a field around given points (Fig. 1 check)."""
import numpy as np


def blob_centroids(values, coordinates, centres, radius):
    """Centroid of ``values`` (>= 0, e.g. |t| on grid nodes) around each of ``centres``.

    Each node within ``radius`` of a centre is given to its nearest centre (so neighbouring
    blobs are not mixed), and each centre's nodes are averaged weighted by ``values``.

    Parameters
    ----------
    values : (n_nodes,) array
    coordinates : (n_nodes, D) array
    centres : (M, D) array
    radius : float

    Returns
    -------
    (M, D) array of centroids (NaN where no node is within ``radius``).
    """
    values = np.asarray(values, float).reshape(-1)
    coordinates = np.asarray(coordinates, float).reshape(values.size, -1)
    centres = np.asarray(centres, float)
    dist = np.linalg.norm(coordinates[:, None, :] - centres[None, :, :], axis=2)
    owner = np.argmin(dist, axis=1)
    out = np.full(centres.shape, np.nan)
    for k in range(len(centres)):
        mine = (owner == k) & (dist[:, k] <= radius)
        weight = values[mine]
        if weight.sum() > 0:
            out[k] = (weight[:, None] * coordinates[mine]).sum(axis=0) / weight.sum()
    return out
