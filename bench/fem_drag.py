"""The drag of tests/data/gmsh/flow_box.geo's body by finite elements: steady
incompressible Navier-Stokes, Taylor-Hood P2-P1 (dolfinx 0.5.2, Debian 12's
python3-dolfinx), Newton with MUMPS.  An independent reference for the
OpenFOAM drags of bench/solver.sh (docs/results.md, "A CFD solver on the
outputs"; docs/benchmarks.md, thirty-second session).

usage: OMP_NUM_THREADS=1 [mpirun -n 2] /usr/bin/python3 bench/fem_drag.py MESH [--nus 0.04,0.02,0.01]
       [--sym] [--p1]
MESH: a .mesh of flow_box.geo (gmsh's, tetgen's or tetopt's: any tets of
that domain; the boundary is found by coordinates).  Prints a RESULT line
per viscosity of the continuation and a FINAL line: Cd_surface (the
stress integrated over the body) and Cd_reaction (the momentum residual
tested with e_x on the body's velocity dofs: the more accurate).  MUMPS is
about 18 times faster with OpenBLAS (Debian's libopenblas0-pthread) than
with the reference BLAS; at the s = 0.5 mesh (83k unknowns) one
factorisation takes about 10 s and 1.4 GB with it.

Domain box [-2,4]x[-1,1]^2 minus the body; boundary facets by coordinates:
 inlet x=-2: u=(1,0,0); outlet x=4: natural; y=+-1: u_y=0; z=+-1: u_z=0 (slip);
 body (all other boundary facets): u=0.  nu = 0.01 at the end (Reynolds
 number 120 on the body's length 1.2), as bench/foam_case.sh's simpleFoam.
Default viscous form: nu grad u : grad v  (natural outflow: nu du/dn - p n = 0, closest to
OpenFOAM's p=0 / zeroGradient U). --sym: 2 nu eps(u):eps(v) (outflow: sigma n = 0).
On the flat slip walls both forms give the same natural (tangential-traction-free) condition.
--p1: P1-P1 with SUPG/PSPG stabilisation instead (cheaper, far less accurate).
"""
import sys, time, argparse
import numpy as np
from mpi4py import MPI
from petsc4py import PETSc
import ufl
import dolfinx
from dolfinx import fem, mesh as dmesh
from dolfinx.fem.petsc import NonlinearProblem
from dolfinx.nls.petsc import NewtonSolver

ap = argparse.ArgumentParser()
ap.add_argument("mesh")
ap.add_argument("--nus", default="0.04,0.02,0.01")
ap.add_argument("--sym", action="store_true")
ap.add_argument("--p1", action="store_true")  # P1-P1 with SUPG/PSPG stabilisation instead of P2-P1
ap.add_argument("--aref", type=float, default=0.197)
ap.add_argument("--rtol", type=float, default=1e-9)
args = ap.parse_args()

comm = MPI.COMM_WORLD
rank = comm.rank
t0 = time.time()

def pr(*a):
    if rank == 0:
        print(*a, flush=True)

# ---- read mesh (rank 0) ----
if rank == 0:
    import meshio
    m = meshio.read(args.mesh)
    tets = np.asarray(m.cells_dict["tetra"], dtype=np.int64)
    used = np.unique(tets)
    remap = -np.ones(len(m.points), dtype=np.int64)
    remap[used] = np.arange(len(used))
    cells = remap[tets]
    x = np.asarray(m.points[used, :3], dtype=np.float64)
    ntet = len(tets)
else:
    cells = np.empty((0, 4), dtype=np.int64)
    x = np.empty((0, 3), dtype=np.float64)
    ntet = 0
ntet = comm.bcast(ntet, root=0)
domain = ufl.Mesh(ufl.VectorElement("Lagrange", "tetrahedron", 1))
msh = dmesh.create_mesh(comm, cells, x, domain)
tdim = msh.topology.dim
fdim = tdim - 1
msh.topology.create_connectivity(fdim, tdim)

eps_ = 1e-6
inlet = dmesh.locate_entities_boundary(msh, fdim, lambda x: np.isclose(x[0], -2.0, atol=eps_))
outlet = dmesh.locate_entities_boundary(msh, fdim, lambda x: np.isclose(x[0], 4.0, atol=eps_))
ywall = dmesh.locate_entities_boundary(msh, fdim, lambda x: np.isclose(np.abs(x[1]), 1.0, atol=eps_))
zwall = dmesh.locate_entities_boundary(msh, fdim, lambda x: np.isclose(np.abs(x[2]), 1.0, atol=eps_))
body = dmesh.locate_entities_boundary(
    msh, fdim, lambda x: (np.abs(x[1]) < 0.9) & (np.abs(x[2]) < 0.9) & (x[0] > -1.9) & (x[0] < 3.9))
allb = dmesh.exterior_facet_indices(msh.topology)
nloc = [len(a) for a in (inlet, outlet, ywall, zwall, body, allb)]
ntot = comm.allreduce(np.array(nloc), op=MPI.SUM)  # ghosts may double count; only a sanity check
pr("facets inlet,outlet,ywall,zwall,body,all-exterior (local sums):", ntot.tolist())

fidx = np.concatenate([inlet, outlet, ywall, zwall, body])
fval = np.concatenate([np.full(len(inlet), 1), np.full(len(outlet), 2), np.full(len(ywall), 3),
                       np.full(len(zwall), 5), np.full(len(body), 4)]).astype(np.int32)
order = np.argsort(fidx)
ft = dmesh.meshtags(msh, fdim, fidx[order].astype(np.int32), fval[order])
ds = ufl.Measure("ds", domain=msh, subdomain_data=ft)

# ---- spaces ----
P2 = ufl.VectorElement("Lagrange", msh.ufl_cell(), 1 if args.p1 else 2)
P1 = ufl.FiniteElement("Lagrange", msh.ufl_cell(), 1)
W = fem.FunctionSpace(msh, ufl.MixedElement([P2, P1]))
V0, _ = W.sub(0).collapse()
ndofs = W.dofmap.index_map.size_global * W.dofmap.index_map_bs
pr(f"mesh {args.mesh}: {ntet} tets, {msh.topology.index_map(0).size_global} vertices, {ndofs} dofs")

# ---- BCs ----
u_in = fem.Function(V0)
u_in.interpolate(lambda x: np.vstack((np.ones(x.shape[1]), np.zeros(x.shape[1]), np.zeros(x.shape[1]))))
u_zero = fem.Function(V0)
dofs_in = fem.locate_dofs_topological((W.sub(0), V0), fdim, inlet)
dofs_body = fem.locate_dofs_topological((W.sub(0), V0), fdim, body)
bcs = [fem.dirichletbc(u_zero, dofs_body, W.sub(0)),
       fem.dirichletbc(PETSc.ScalarType(0), fem.locate_dofs_topological(W.sub(0).sub(1), fdim, ywall), W.sub(0).sub(1)),
       fem.dirichletbc(PETSc.ScalarType(0), fem.locate_dofs_topological(W.sub(0).sub(2), fdim, zwall), W.sub(0).sub(2)),
       fem.dirichletbc(u_in, dofs_in, W.sub(0))]  # inlet last: wins on inlet/side edges (consistent anyway)

# ---- forms ----
wsol = fem.Function(W)
u, p = ufl.split(wsol)
v, q = ufl.TestFunctions(W)
nu = fem.Constant(msh, PETSc.ScalarType(0.04))

def eps(a):
    return ufl.sym(ufl.grad(a))

def visc(a, b):
    if args.sym:
        return 2 * nu * ufl.inner(eps(a), eps(b))
    return nu * ufl.inner(ufl.grad(a), ufl.grad(b))

hK = ufl.CellDiameter(msh)

def residual(v, q):
    r = visc(u, v) + ufl.inner(ufl.grad(u) * u, v) - p * ufl.div(v)
    if q is not None:
        r = r + q * ufl.div(u)
    if args.p1:
        # SUPG/PSPG (strong residual; viscous term vanishes for P1 on affine cells)
        unorm = ufl.sqrt(ufl.dot(u, u) + 1e-12)
        tau = ((2 * unorm / hK) ** 2 + 9 * (4 * nu / hK ** 2) ** 2) ** (-0.5)
        res = ufl.grad(u) * u + ufl.grad(p)
        t = ufl.grad(v) * u
        if q is not None:
            t = t + ufl.grad(q)
        r = r + tau * ufl.inner(res, t)
    if args.p1:
        return r * ufl.dx(metadata={"quadrature_degree": 3})
    return r * ufl.dx

F = residual(v, q)
J = ufl.derivative(F, wsol, ufl.TrialFunction(W))

# drag functionals
n = ufl.FacetNormal(msh)  # outward from the fluid = into the body
sigma = -p * ufl.Identity(3) + 2 * nu * eps(u)
ex = ufl.as_vector((1.0, 0.0, 0.0))
# force of fluid on body = -int_body sigma n_out ds
Fs_form = fem.form(-ufl.inner(sigma * n, ex) * ds(4))
Fp_form = fem.form(p * ufl.inner(n, ex) * ds(4))  # pressure part of the surface force
Fv_form = fem.form(-ufl.inner(2 * nu * eps(u) * n, ex) * ds(4))  # viscous part
# reaction: w = e_x on body dofs, 0 elsewhere (P2); Fx = -R(u,p;w)
wx = fem.Function(V0)
bdofs_V0 = fem.locate_dofs_topological(V0, fdim, body)
bs = V0.dofmap.index_map_bs
wx.x.array[bdofs_V0 * bs + 0] = 1.0
wx.x.scatter_forward()
R_form = fem.form(-residual(wx, None))
area_form = fem.form(1.0 * ds(4))
proj_form = fem.form(ufl.inner(n, -ex) * ufl.conditional(ufl.gt(ufl.inner(n, -ex), 0), 1, 0) * ds(4))

def scal(f):
    return comm.allreduce(fem.assemble_scalar(f), op=MPI.SUM)

pr(f"body area {scal(area_form):.5f}, projected frontal area (n_x<0 part of outward-from-body normal) {scal(proj_form):.5f}")

problem = NonlinearProblem(F, wsol, bcs=bcs, J=J)
solver = NewtonSolver(comm, problem)
solver.convergence_criterion = "residual"
solver.rtol = args.rtol
solver.atol = 1e-11
solver.max_it = 30
solver.report = True
ksp = solver.krylov_solver
opts = PETSc.Options()
pfx = ksp.getOptionsPrefix()
opts[f"{pfx}ksp_type"] = "preonly"
opts[f"{pfx}pc_type"] = "lu"
opts[f"{pfx}pc_factor_mat_solver_type"] = "mumps"
opts[f"{pfx}mat_mumps_icntl_14"] = 200
ksp.setFromOptions()

# print Newton residuals
dolfinx.log.set_log_level(dolfinx.log.LogLevel.INFO)

total_its = 0
nus = [float(s) for s in args.nus.split(",")]
for nuv in nus:
    nu.value = nuv
    t1 = time.time()
    its, conv = solver.solve(wsol)
    wsol.x.scatter_forward()
    total_its += its
    Cs = scal(Fs_form) / (0.5 * args.aref)
    Cr = scal(R_form) / (0.5 * args.aref)
    pr(f"SPLIT nu={nuv} Cd_pressure={scal(Fp_form)/(0.5*args.aref):.5f} Cd_viscous={scal(Fv_form)/(0.5*args.aref):.5f}")
    pr(f"RESULT nu={nuv} its={its} conv={conv} Cd_surface={Cs:.5f} Cd_reaction={Cr:.5f} "
       f"step_s={time.time()-t1:.1f} total_s={time.time()-t0:.1f}")
dolfinx.log.set_log_level(dolfinx.log.LogLevel.WARNING)
pr(f"FINAL mesh={args.mesh} tets={ntet} dofs={ndofs} sym={args.sym} newton_its_total={total_its} "
   f"Cd_surface={Cs:.5f} Cd_reaction={Cr:.5f} seconds={time.time()-t0:.1f} np={comm.size} p1={args.p1}")
