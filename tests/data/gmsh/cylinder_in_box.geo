// cylinder_in_box.geo -- two regions: a tilted cylinder (region 2) inside a box
// (region 1); BooleanFragments keeps the interface conformal; OpenCASCADE.
// Physical surfaces: outer box faces (1), interface (2).  bench/sweep.sh.
SetFactory("OpenCASCADE");
DefineConstant[ h = 0.08 ];
Box(1) = {0, 0, 0, 2, 1.2, 1.2};
Cylinder(2) = {0.6, 0.6, 0.3, 0.8, 0, 0.6, 0.3};
v() = BooleanFragments{ Volume{1}; Delete; }{ Volume{2}; Delete; };
// the cylinder is the fragment whose bounding box lies inside the box
cyl() = Volume In BoundingBox{0.01, 0.01, 0.01, 1.99, 1.19, 1.19};
box() = v();
box() -= cyl();
sc() = Abs(Boundary{ Volume{cyl()}; });
sa() = Abs(Boundary{ Volume{box()}; });
sa() -= sc();
Mesh.MeshSizeMax = h;
Mesh.MeshSizeMin = h/2;
Mesh.MeshSizeFromCurvature = 16;
Physical Surface("outer", 1) = {sa()};
Physical Surface("interface", 2) = {sc()};
Physical Volume("box", 1) = {box()};
Physical Volume("cyl", 2) = {cyl()};
