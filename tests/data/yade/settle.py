# A few dozen spheres settling on a fixed bed of spheres with a floor under it, for cgbound's Yade reader.
# Run as:  CGBOUND_YADE_OUT=dir CGBOUND_YADE_PERIODIC=0|1 CGBOUND_YADE_EXPORT=.../yade_export.py yade -n -x settle.py
# Non-periodic: a Wall floor (z = 0) and four side Walls (x = 0, 4 and y = 0, 4).
# Periodic (cell 4 x 4 x 8): a floor of 1 x 1 Facets (a Wall is not allowed in a periodic cell).
# Writes frames with export_frame (a PyRunner, last engine) and <dir>/yade_summary.json with what Yade itself
# reports at the last frame (counts, masses, total forces on the boundary bodies).
import json
import os
import random

exec(open(os.environ["CGBOUND_YADE_EXPORT"]).read())
out = os.environ["CGBOUND_YADE_OUT"]
periodic = os.environ.get("CGBOUND_YADE_PERIODIC", "0") == "1"
rng = random.Random(7)  # utils.sphere draws colours from the global generator

mat = O.materials.append(FrictMat(young=1e6, poisson=0.3, density=1000, frictionAngle=0.5))
L = 4.0
boundary = []
if periodic:
    O.periodic = True
    O.cell.setBox(L, L, 8.0)
    for a in range(4):
        for b in range(4):
            x0, y0 = float(a), float(b)
            for tri in (((x0, y0, 0), (x0 + 1, y0, 0), (x0 + 1, y0 + 1, 0)), ((x0, y0, 0), (x0 + 1, y0 + 1, 0), (x0, y0 + 1, 0))):
                boundary.append(O.bodies.append(utils.facet(tri, fixed=True, material=mat)))
else:
    boundary.append(O.bodies.append(utils.wall(0.0, axis=2, material=mat)))
    boundary.append(O.bodies.append(utils.wall(0.0, axis=0, material=mat)))
    boundary.append(O.bodies.append(utils.wall(L, axis=0, material=mat)))
    boundary.append(O.bodies.append(utils.wall(0.0, axis=1, material=mat)))
    boundary.append(O.bodies.append(utils.wall(L, axis=1, material=mat)))
bed = []
for a in range(4):
    for b in range(4):
        bed.append(O.bodies.append(utils.sphere((a + 0.5, b + 0.5, 0.3), 0.3, fixed=True, material=mat)))
flow = []
for k in range(40):
    x, y = 0.35 + (L - 0.7) * rng.random(), 0.35 + (L - 0.7) * rng.random()
    z = 1.0 + 0.6 * k / 4
    flow.append(O.bodies.append(utils.sphere((x, y, z), 0.2 + 0.08 * rng.random(), material=mat)))

O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb(), Bo1_Wall_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Facet_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom()],
                    [Ip2_FrictMat_FrictMat_FrictPhys()], [Law2_ScGeom_FrictPhys_CundallStrack()]),
    NewtonIntegrator(gravity=(0, 0, -9.81), damping=0.3),
    PyRunner(command='export_frame(out)', iterPeriod=1000, initRun=False),
]
O.dt = 0.4 * PWaveTimeStep()
O.run(4000, True)
export_frame(out)  # the last frame, which the summary below describes

# what Yade itself says (at the last frame): counts, masses and the total force on the boundary bodies
fixed_force = [0.0, 0.0, 0.0]
for bid in boundary + bed:
    f = O.forces.f(bid)
    for c in range(3):
        fixed_force[c] += float(f[c])
summary = dict(iter=O.iter, time=float(O.time), n_flow=len(flow), n_bed=len(bed), n_boundary=len(boundary),
               flow_mass=sum(float(O.bodies[b].state.mass) for b in flow),
               boundary_force=fixed_force, n_interactions=sum(1 for i in O.interactions if i.isReal),
               max_z=max(float(O.bodies[b].state.pos[2]) for b in flow))
with open(os.path.join(out, "yade_summary.json"), "w") as fh:
    json.dump(summary, fh, indent=1)
print("CGBOUND_YADE_DONE", json.dumps(summary))
