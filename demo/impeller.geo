// impeller.geo -- a centrifugal-pump-like closed impeller in its casing, for the
// tetopt demo.  Two regions share an interface:
//   region 1 "solid": hub disk with a boss and a shaft stub, NB thin
//                     backward-curved (logarithmic-spiral) blades, and an annular
//                     shroud with an open eye;
//   region 2 "fluid": the casing cylinder around it, minus the solid (the blade
//                     passages, the eye, the gaps above, below and around).
// Lengths in metres: outlet radius R = 0.1, blade thickness 3 mm (3 % of R).
//
// Size: one parameter s (default 1, about 430k tets).  s = 2 gives about 8x
// fewer tets.  From the command line:   gmsh -3 -setnumber s 2 impeller.geo
//
// The mesh is deliberately left as the mesher makes it: 3-D Delaunay, no
// optimisation (Mesh.Optimize = 0, Mesh.OptimizeNetgen = 0), curvature-based
// sizing on the thin curved blades -- which is what produces slivers in real
// meshes.

SetFactory("OpenCASCADE");

DefineConstant[ s = {1.0, Min 0.25, Max 8, Name "Parameters/size factor s"} ];
DefineConstant[ NB = {6, Min 2, Max 12, Step 1, Name "Parameters/number of blades"} ];

R     = 0.100;   // impeller outlet radius
Rin   = 0.030;   // blade leading-edge radius
Reye  = 0.045;   // shroud eye radius
Rboss = 0.020;   // hub boss radius
Rsh   = 0.010;   // shaft radius
hHub  = 0.010;   // hub disk thickness (z = 0 .. hHub)
hBoss = 0.012;   // boss height above the hub disk
bBl   = 0.020;   // blade height (hub top .. shroud bottom)
hShr  = 0.005;   // shroud thickness
tBl   = 0.003;   // blade thickness
beta  = 32 * Pi / 180;  // blade angle to the tangent (log spiral)
Rc    = 0.125;   // casing radius
zc0   = -0.020;  // casing bottom
zc1   = 0.065;   // casing top

zSb = hHub + bBl;   // shroud bottom
zSt = zSb + hShr;   // shroud top

// ---- solid -----------------------------------------------------------------
hub   = newv; Cylinder(hub)   = {0, 0, 0,    0, 0, hHub, R};
boss  = newv; Cylinder(boss)  = {0, 0, hHub, 0, 0, hBoss, Rboss};
shaft = newv; Cylinder(shaft) = {0, 0, zc0,  0, 0, -zc0, Rsh};
ring  = newv; Cylinder(ring)  = {0, 0, zSb,  0, 0, hShr, R};
eye   = newv; Cylinder(eye)   = {0, 0, zSb - 0.001, 0, 0, hShr + 0.002, Reye};
shroud() = BooleanDifference{ Volume{ring}; Delete; }{ Volume{eye}; Delete; };

// One blade: a log spiral r = Rin exp(th tan(beta)) as centre line, offset by
// +-tBl/2 along its normal, closed by straight ends, extruded from inside the
// hub to the shroud bottom.  The spiral runs past R and is trimmed by a
// cylinder of radius R, so the trailing edge lies on the outlet surface.
thEnd = Log(1.06 * R / Rin) / Tan(beta);
np = 16;
blades[] = {};
For k In {0 : NB - 1}
  ph = 2 * Pi * k / NB;
  pl[] = {}; pr[] = {};
  For i In {0 : np}
    th = thEnd * i / np;
    r  = Rin * Exp(th * Tan(beta));
    // position on the centre line, unit tangent (dr, r dth) -> normal
    cx = r * Cos(th + ph); cy = r * Sin(th + ph);
    tx = Sin(beta) * Cos(th + ph) - Cos(beta) * Sin(th + ph);
    ty = Sin(beta) * Sin(th + ph) + Cos(beta) * Cos(th + ph);
    nx = -ty; ny = tx;
    pl[] += newp; Point(pl[i]) = {cx + 0.5 * tBl * nx, cy + 0.5 * tBl * ny, hHub / 2};
    pr[] += newp; Point(pr[i]) = {cx - 0.5 * tBl * nx, cy - 0.5 * tBl * ny, hHub / 2};
  EndFor
  c1 = newl; Spline(c1) = pl[];
  c2 = newl; Line(c2) = {pl[np], pr[np]};
  c3 = newl; Spline(c3) = pr[{np : 0 : -1}];
  c4 = newl; Line(c4) = {pr[0], pl[0]};
  cl = newll; Curve Loop(cl) = {c1, c2, c3, c4};
  ps = news; Plane Surface(ps) = {cl};
  ex[] = Extrude {0, 0, zSb - hHub / 2} { Surface{ps}; };
  blades[] += ex[1];
EndFor
trim = newv; Cylinder(trim) = {0, 0, zc0, 0, 0, zc1 - zc0, R};
bl() = BooleanIntersection{ Volume{blades[]}; Delete; }{ Volume{trim}; Delete; };

solid() = BooleanUnion{ Volume{hub}; Delete; }{ Volume{boss, shaft, shroud(), bl()}; Delete; };

// ---- fluid: casing minus solid, sharing the solid's surface ------------------
casing = newv; Cylinder(casing) = {0, 0, zc0, 0, 0, zc1 - zc0, Rc};
all() = BooleanFragments{ Volume{casing}; Delete; }{ Volume{solid()}; Delete; };

e = 1e-4;
vs() = Volume In BoundingBox{-R - e, -R - e, zc0 - e, R + e, R + e, zSt + e};
vf() = Volume In BoundingBox{-Rc - e, -Rc - e, zc0 - e, Rc + e, Rc + e, zc1 + e};
vf() -= vs();

Physical Volume("solid", 1) = {vs()};
Physical Volume("fluid", 2) = {vf()};

// surfaces: the interface (every wall of the solid inside the casing), the
// casing wall, and the shaft's cross-section where it leaves the casing
sAll() = Boundary{ Volume{vf()}; };
sSol() = Boundary{ Volume{vs()}; };
sCas() = Surface In BoundingBox{-Rc - e, -Rc - e, zc0 - e, Rc + e, Rc + e, zc1 + e};
sCas() -= sSol();
sOut() = sSol();
sOut() -= sAll();
sWall() = sSol();
sWall() -= sOut();
Physical Surface("walls", 11) = {sWall()};
Physical Surface("casing", 12) = {sCas()};
Physical Surface("shaft_end", 13) = {sOut()};

// ---- mesh size ---------------------------------------------------------------
Mesh.MeshSizeFromCurvature = 24;      // elements per 2 pi on curved walls
Mesh.MeshSizeFactor = s;            // scales every size (applied after the Min/Max clamp)
Mesh.MeshSizeMin = 0.0012;
Mesh.MeshSizeMax = 0.0037;
Mesh.MeshSizeExtendFromBoundary = 1;
Mesh.MeshSizeFromPoints = 0;

Mesh.Algorithm = 6;        // Frontal-Delaunay surfaces
Mesh.Algorithm3D = 1;      // Delaunay volumes
Mesh.Optimize = 0;         // keep the mesh as poor as the mesher makes it
Mesh.OptimizeNetgen = 0;
Mesh.SaveAll = 0;          // save physical groups only (both volumes, walls)
Mesh.SaveElementTagType = 2;  // Medit refs = physical tags (1 solid, 2 fluid)
