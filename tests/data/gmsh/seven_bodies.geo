// seven_bodies.geo -- a CFD box with 7 small bodies removed (4 spheres, 3
// cylinders of different radii and axes; their insides are holes), OpenCASCADE.
// bench/sweep.sh.
SetFactory("OpenCASCADE");
DefineConstant[ h = 0.09, hs = 0.03 ];
Box(1) = {0, 0, 0, 3, 1.5, 1.5};
Sphere(2) = {0.5, 0.5, 0.5, 0.15};
Sphere(3) = {0.9, 1.0, 0.9, 0.1};
Sphere(4) = {1.5, 0.4, 1.1, 0.2};
Sphere(5) = {2.4, 0.8, 0.5, 0.12};
Cylinder(6) = {1.2, 0.75, 0.3, 0, 0, 0.7, 0.08};
Cylinder(7) = {1.9, 0.3, 0.75, 0, 0.8, 0, 0.1};
Cylinder(8) = {2.2, 1.1, 1.0, 0.5, 0, 0, 0.07};
BooleanDifference(10) = { Volume{1}; Delete; }{ Volume{2:8}; Delete; };
Mesh.MeshSizeMax = h;
Mesh.MeshSizeMin = hs;
Mesh.MeshSizeFromCurvature = 20;
Physical Surface("walls", 1) = {Surface{:}};
Physical Volume("fluid", 1) = {10};
