// plate_stack.geo -- three 1x1 plates 1/30 thick, 0.3 apart, joined by five posts
// (4 corner posts, one centre post), OpenCASCADE.  At h = 0.04 the plates are
// one or two tets thick.  bench/sweep.sh.
SetFactory("OpenCASCADE");
DefineConstant[ h = 0.04 ];
t = 1/30;
Box(1) = {0, 0, 0, 1, 1, t};
Box(2) = {0, 0, 0.3, 1, 1, t};
Box(3) = {0, 0, 0.6, 1, 1, t};
Cylinder(4) = {0.1, 0.1, t, 0, 0, 0.6-t, 0.05};
Cylinder(5) = {0.9, 0.1, t, 0, 0, 0.6-t, 0.05};
Cylinder(6) = {0.1, 0.9, t, 0, 0, 0.6-t, 0.05};
Cylinder(7) = {0.9, 0.9, t, 0, 0, 0.6-t, 0.05};
Cylinder(8) = {0.5, 0.5, t, 0, 0, 0.6-t, 0.08};
BooleanUnion(10) = { Volume{1}; Delete; }{ Volume{2:8}; Delete; };
Mesh.MeshSizeMax = h;
Mesh.MeshSizeMin = h/2;
Physical Surface("skin", 1) = {Surface{:}};
Physical Volume("solid", 1) = {Volume{:}};
