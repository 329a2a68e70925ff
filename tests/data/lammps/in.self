# cgbound test case: 12 spheres (diameters 0.85..1.0) in a fully periodic box only 0.95 wide along x, less than the
# larger diameters: a particle touches its own periodic image, and LAMMPS' pair/local lists it with itself (patom1 ==
# patom2; here 8 such rows with a force, and 4 without: images within the cutoff, not touching). pair granular
# (hooke, linear_history), compressed along y and z (fix deform) then read in a "run 0" frame (%.17g). Produces (run
# in tests/data/lammps/self: lmp -in ../in.self) atoms.dump / pairs.dump, one frame. cgbound does not model
# self-contacts: the reader refuses the frame naming the periodic length and the diameter. Used by
# tests/test_contact_geometry.py.
units           lj
atom_style      sphere
dimension       3
boundary        p p p
comm_modify     vel yes
region          box block 0 0.95 0 4.2 0 4.2
create_box      1 box
create_atoms    1 random 12 5151 NULL
variable        dd atom 0.85+0.15*random(0,1,77)
set             type 1 diameter v_dd
set             type * density 1.0
velocity        all create 0.5 4321 loop geom
pair_style      granular
pair_coeff      * * hooke 1000.0 20.0 tangential linear_history 300.0 1.0 0.5
fix             integ all nve/sphere
fix             visc all viscous 0.5    # (damps the compression; removed before the frames: not a contact force)
timestep        0.001
compute         pl all pair/local dist fx fy fz p1 p2 p3 p4 p5 p6 p7 p8 p9 p10 p11 p12
compute         pp all property/local patom1 patom2
thermo          1000
run             3000
fix             def all deform 1 y final 0 3.3 z final 0 3.3 remap x
run             4000
unfix           def
unfix           visc
run             300
dump            a all custom 1 atoms.dump id type x y z vx vy vz fx fy fz radius mass
dump            c all local 1 pairs.dump index c_pp[*] c_pl[*]
dump_modify     a format float %.17g
dump_modify     c format float %.17g
run             0
undump          a
undump          c
