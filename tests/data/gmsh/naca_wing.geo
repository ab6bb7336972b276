// naca_wing.geo -- a NACA 0012 wing (chord 1, the closed trailing-edge form of the
// thickness polynomial, so the trailing edge is sharp; span 0.6 from z = 0.2)
// as a hole in a flow box [-1,3] x [-1,1] x [0,1] (OpenCASCADE): fine at the
// wing (hb), coarse at the box (hf).  The thickness is Abbott & von
// Doenhoff's (Theory of Wing Sections, 1959, §6.4) with -0.1036 as the last
// coefficient; 80 points with cosine spacing.  bench/sweep.sh.
SetFactory("OpenCASCADE");
DefineConstant[ hb = {0.02, Min 0.002, Max 0.1, Name "wing size"}, hf = 0.25 ];
n = 80;
For i In {0:n-1}
  th = 2 * Pi * i / n;
  x = 0.5 * (1 + Cos(th));
  y = 0.6 * (0.2969 * Sqrt(Fabs(x)) - 0.1260 * x - 0.3516 * x^2 + 0.2843 * x^3 - 0.1036 * x^4);
  If (i > n / 2)
    y = -y;
  EndIf
  Point(i+1) = {x, y, 0.2, hb};
EndFor
Spline(1) = {1:n/2+2};
Spline(2) = {n/2+2:n, 1};
Curve Loop(1) = {1, 2};
Plane Surface(1) = {1};
w[] = Extrude {0, 0, 0.6} { Surface{1}; };
Box(100) = {-1, -1, 0, 4, 2, 1};
BooleanDifference(101) = { Volume{100}; Delete; }{ Volume{w[1]}; Delete; };
MeshSize{ PointsOf{ Volume{101}; } } = hf;
MeshSize{ Point In BoundingBox{-0.01, -0.2, 0.19, 1.01, 0.2, 0.81} } = hb;
Mesh.MeshSizeFromCurvature = 40;
Mesh.MeshSizeMin = hb;
Mesh.MeshSizeMax = hf;
Physical Surface("walls", 1) = {Surface{:}};
Physical Volume("fluid", 1) = {101};
