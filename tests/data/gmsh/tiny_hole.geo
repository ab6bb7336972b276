// tiny_hole.geo -- a unit box with a spherical hole 1e4 times smaller
// (radius r = 1e-4 by default): a feature far finer than the part around
// it, for the remesher's size field (tests/scripts/test_tiny_feature.sh).
// gmsh grades away from the sphere within a few tets (surface edges about
// 7e-5, the next vertices 1.6e-3 away), and `tetgen -pQ` of the surface
// joins the sphere straight to the box.
SetFactory("OpenCASCADE");
DefineConstant[ r = {1e-4, Min 1e-6, Max 0.1, Name "hole radius"} ];
Box(1) = {0, 0, 0, 1, 1, 1};
Sphere(2) = {0.5, 0.5, 0.5, r};
BooleanDifference{ Volume{1}; Delete; }{ Volume{2}; Delete; }
Mesh.MeshSizeMax = 0.1;
Mesh.MeshSizeFromCurvature = 8;
