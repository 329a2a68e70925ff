# %% [markdown]
# # cgbound quickstart
#
# Continuum fields from the steady chute flow shipped with cgbound (LAMMPS, the paper's Figs. 2-3:
# 1000 particles on a rough base inclined at 26°, frames in t = [2000, 2100]).

# %%
import cgbound as cg
from cgbound import plot
from cgbound.datasets import chute_steady

frames = chute_steady()                 # lazy: frames are read when used
frames[0]

# %%
grid = cg.Grid(frames[0].box, (1, 1, 240), average=("x", "y"))   # a depth profile: x and y averaged analytically
kernel = cg.Gaussian(width=0.25)                                   # w = d/4
fields = ("density", "velocity", "stress", "interaction_force_density")
out = cg.CoarseGrain(frames, grid, kernel, fields=fields, convention="compression").run().results
out

# %%
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
fig, axes = plt.subplots(1, 3, figsize=(11, 3.8), sharey=True, constrained_layout=True)
plot.profile(out, "density", ax=axes[0])
plot.profile(out, "velocity", component="x", ax=axes[1])
plot.profile(out, "stress", component="zz", ax=axes[2])
fig

# %% [markdown]
# The boundary contacts show up as the interaction force density: it carries the weight of the flow
# into the base (per unit area of the chute: 1000 m g cos 26° / (20 × 10)).

# %%
import numpy as np
dz = grid.spacing[-1]
carried = out.interaction_force_density[..., 2].sum() * dz
weight = 1000 * np.cos(np.radians(26)) / 200
print(f"IFD carries {carried:.4f} per unit area; weight of the flow {weight:.4f}")
assert abs(carried / weight - 1) < 0.01
