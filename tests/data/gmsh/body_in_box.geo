// body_in_box.geo -- a CFD-like domain for the remesher's tests (issue 27):
// a flow box with an ellipsoidal body and a thin fin inside it, meshed as a
// surface only (gmsh -2).  `tetgen -pQ` of that surface gives what a user
// gets from a raw constrained Delaunay tetrahedralisation: almost every tet
// has all four vertices on the boundary and there are no interior vertices.
// The body's surface is fine (h = 0.08 * s) and the box's coarse (0.5 * s),
// so the interior needs a size gradation.
SetFactory("OpenCASCADE");
DefineConstant[ s = {1.0, Min 0.25, Max 4, Name "size factor"} ];
Box(1) = {-2, -1, -1, 6, 2, 2};
Sphere(2) = {0, 0, 0, 0.4};
Dilate {{0, 0, 0}, {1.5, 0.6, 0.6}} { Volume{2}; }
Box(3) = {0.3, -0.02, 0.1, 0.5, 0.04, 0.4};
BooleanUnion(4) = { Volume{2}; Delete; }{ Volume{3}; Delete; };
BooleanDifference(5) = { Volume{1}; Delete; }{ Volume{4}; Delete; };
Mesh.MeshSizeMin = 0.04 * s;
Mesh.MeshSizeMax = 0.5 * s;
MeshSize{ PointsOf{ Volume{5}; } } = 0.5 * s;
Field[1] = Distance;
Field[1].SurfacesList = {Surface{:}};
Field[2] = MathEval;
Field[2].F = Sprintf("%g * (0.08 + 0.3 * Sqrt(x*x/2.25 + y*y + z*z))", s);
Background Field = 2;
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeFromCurvature = 0;
Physical Surface("walls", 1) = {Surface{:}};
Physical Volume("fluid", 1) = {5};
