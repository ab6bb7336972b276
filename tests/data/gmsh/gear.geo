// gear.geo -- a spur gear: N = 24 trapezoidal teeth between a root circle of
// radius 0.92 and a tip circle of radius 1 (each tooth rises from the root
// at 0, reaches the tip from 0.18 to 0.42 of its pitch and is back at the
// root at 0.6), a bore of radius 0.3, extruded 0.25 (OpenCASCADE).  Sharp
// tooth edges repeated 24 times: a symmetric part whose locked tets come in
// copies.  bench/sweep.sh; gmsh -3 -setnumber h 0.035 gear.geo.
SetFactory("OpenCASCADE");
DefineConstant[ h = {0.035, Min 0.005, Max 0.2, Name "size"} ];
N = 24; rr = 0.92; rt = 1.0; p = 2 * Pi / N;
For k In {0:N-1}
  a = k * p;
  Point(4*k+1) = {rr * Cos(a), rr * Sin(a), 0, h};
  Point(4*k+2) = {rt * Cos(a + 0.18*p), rt * Sin(a + 0.18*p), 0, h};
  Point(4*k+3) = {rt * Cos(a + 0.42*p), rt * Sin(a + 0.42*p), 0, h};
  Point(4*k+4) = {rr * Cos(a + 0.6*p), rr * Sin(a + 0.6*p), 0, h};
EndFor
For i In {1:4*N}
  Line(i) = {i, (i % (4*N)) + 1};
EndFor
Curve Loop(1) = {1:4*N};
Circle(4*N+1) = {0, 0, 0, 0.3};
Curve Loop(2) = {4*N+1};
Plane Surface(1) = {1, 2};
out[] = Extrude {0, 0, 0.25} { Surface{1}; };
Physical Surface("walls", 1) = {Surface{:}};
Physical Volume("gear", 1) = {out[1]};
