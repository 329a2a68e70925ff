# %% [markdown]
# # cgbound quickstart
#
# Continuum fields from the steady chute flow shipped with cgbound (LAMMPS, the paper's Figs. 2-3:
# 1000 particles on a rough base inclined at 26°, frames in t = [2000, 2100]).

# %%
import cgbound as cg
from cgbound import plot
from cgbound.paper.datasets import chute_steady

frames = chute_steady()                 # lazy: frames are read when used
frames[0]

# %%
grid = cg.Grid(frames[0].box, (1, 1, 240), average=("x", "y"))   # a depth profile: x and y averaged analytically
kernel = cg.Gaussian(width=0.25)                                   # w = d/4
fields = ("density", "velocity", "stress", "interaction_force_density", "body_force_density")
out = cg.CoarseGrain(frames, grid, kernel, fields=fields, convention="compression").run().results
out

# %%
import matplotlib.pyplot as plt
fig, axes = plt.subplots(1, 3, figsize=(11, 3.8), sharey=True, constrained_layout=True)
plot.profile(out, "density", ax=axes[0])
plot.profile(out, "velocity", component="x", ax=axes[1])
plot.profile(out, "stress", component="zz", ax=axes[2])
plt.show()

# %% [markdown]
# The boundary contacts show up as the interaction force density: on average it carries the weight of
# the flow into the base. The profiles hold the weight exactly (∫ρg dz); the IFD carries it up to the
# sampling error of 101 instantaneous frames of a collisional flow (a few per cent; notebook 03 shows
# the paper's dense sampling closing the balance to 0.2 %).

# %%
import numpy as np
dz = grid.spacing[-1]
weight = 1000 * np.cos(np.radians(26)) / (20 * 10)                  # N m g cos(theta) per unit area
held = -out.body_force_density[..., 2].sum() * dz
carried = out.interaction_force_density[..., 2].sum() * dz
print(f"weight {weight:.4f}; in the profiles {held:.4f}; carried by the IFD {carried:.4f} per unit area")
assert abs(held / weight - 1) < 1e-3
assert abs(carried / weight - 1) < 0.1
