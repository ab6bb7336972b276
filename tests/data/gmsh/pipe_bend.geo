// pipe_bend.geo -- a curved CFD pipe (fluid domain): a straight converging cone
// (radius 0.35 -> 0.2), a 180-degree bend of centreline radius 1 with
// section radius 0.2 (a revolved disk, i.e. a torus section), then a
// diverging cone (0.2 -> 0.3); OpenCASCADE, fused into one volume.
// bench/sweep.sh.
SetFactory("OpenCASCADE");
DefineConstant[ h = 0.05 ];
Cone(1) = {1, -1.2, 0, 0, 1.2, 0, 0.35, 0.2};
Disk(10) = {1, 0, 0, 0.2};
Rotate {{1,0,0},{1,0,0}, Pi/2} { Surface{10}; }
b[] = Extrude {{0,0,1}, {0,0,0}, Pi} { Surface{10}; };
Cone(3) = {-1, 0, 0, 0, -1.5, 0, 0.2, 0.3};
BooleanUnion(4) = { Volume{1}; Delete; }{ Volume{b[1], 3}; Delete; };
Mesh.MeshSizeMax = h;
Mesh.MeshSizeMin = h/3;
Mesh.MeshSizeFromCurvature = 14;
Physical Surface("wall", 1) = {Surface{:}};
Physical Volume("fluid", 1) = {Volume{:}};
