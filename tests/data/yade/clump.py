# A two-sphere clump and a loose sphere settling on 4 fixed spheres over a Wall floor (for the Yade reader).
# Run as: CGBOUND_YADE_OUT=clump/yade_0000003000.npz CGBOUND_YADE_EXPORT=.../yade_export.py yade -n -x clump.py
import os
exec(open(os.environ["CGBOUND_YADE_EXPORT"]).read())
mat = O.materials.append(FrictMat(young=1e6, poisson=0.3, density=1000, frictionAngle=0.5))
O.bodies.append(utils.wall(0.0, axis=2, material=mat))
for k in range(4):
    O.bodies.append(utils.sphere((k*1.0+0.5, 0.5, 0.3), 0.3, fixed=True, material=mat))
cid, mids = O.bodies.appendClumped([utils.sphere((1.2, 0.5, 1.0), 0.25, material=mat), utils.sphere((1.6, 0.5, 1.0), 0.25, material=mat)])
O.bodies.append(utils.sphere((2.5, 0.5, 1.2), 0.25, material=mat))
O.engines = [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Wall_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom()], [Ip2_FrictMat_FrictMat_FrictPhys()], [Law2_ScGeom_FrictPhys_CundallStrack()]),
    NewtonIntegrator(gravity=(0, 0, -9.81), damping=0.3)]
O.dt = 0.4 * PWaveTimeStep()
O.run(3000, True)
for b in O.bodies:  # what Yade reports, for the record
    print(b.id, b.isClump, b.isClumpMember, b.clumpId, b.dynamic, b.state.blockedDOFs, float(b.state.mass), O.forces.f(b.id), b.state.vel)
export_frame(os.environ["CGBOUND_YADE_OUT"])
