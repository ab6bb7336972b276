// A crankshaft-like solid (issue 27 met raw `tetgen -p` output of a
// crankshaft, a CAD part with many sharp edges): main journals on the x
// axis and `throws` throws, each two webs (a disc on the axis and one on the
// pin, 90-degree rims) and a crank pin offset from the axis; an oil hole
// through the first pin.  bench/remesh.sh meshes its surface at s = 0.03
// and gives it to `tetgen -pQ` (crank_raw, 61k tets, no interior vertex):
//   gmsh -2 -setnumber s 0.03 -format stl crank.geo && tetgen -pQ FILE.stl
SetFactory("OpenCASCADE");
DefineConstant[ s = 0.08 ];   // surface element size
DefineConstant[ throws = 3 ];
r_main = 0.25; r_pin = 0.2; off = 0.45; l_j = 0.3; l_w = 0.12; l_p = 0.3;
x = 0; v[] = {};
For k In {0:throws-1}
  v[] += newv; Cylinder(newv) = {x, 0, 0, l_j, 0, 0, r_main}; x += l_j;
  a = 2 * Pi * k / throws;
  cy = off * Cos(a); cz = off * Sin(a);
  // a web: a slab from the axis to the pin, capped by cylinders at both ends
  w1 = newv; Cylinder(w1) = {x, 0, 0, l_w, 0, 0, 0.42};
  w2 = newv; Cylinder(w2) = {x, cy, cz, l_w, 0, 0, 0.32};
  v[] += w1; v[] += w2;
  x += l_w;
  v[] += newv; Cylinder(newv) = {x, cy, cz, l_p, 0, 0, r_pin}; x += l_p;
  w3 = newv; Cylinder(w3) = {x, 0, 0, l_w, 0, 0, 0.42};
  w4 = newv; Cylinder(w4) = {x, cy, cz, l_w, 0, 0, 0.32};
  v[] += w3; v[] += w4;
  x += l_w;
EndFor
v[] += newv; Cylinder(newv) = {x, 0, 0, l_j, 0, 0, r_main};
// an oil hole through the first pin
h = newv; Cylinder(h) = {l_j + l_w + l_p / 2, off, -0.3, 0, 0, 0.6, 0.05};
u() = BooleanUnion{ Volume{v[0]}; Delete; }{ Volume{v[{1:#v[]-1}]}; Delete; };
BooleanDifference{ Volume{u()}; Delete; }{ Volume{h}; Delete; }
Mesh.MeshSizeMax = s;
Mesh.MeshSizeMin = s / 4;
Mesh.MeshSizeFromCurvature = 12;
