// Skin patch between two ribs: a 100 mm x 100 mm slab, 4 mm thick, structured tetrahedra with
// 9 x 8 nodes in the plane and 2 node layers through the thickness (144 nodes).
// Modelled in millimetres, written in metres (Mesh.ScalingFactor).
// Frame: centre of the slab at the origin; the slab spans x in [-50, 50] mm, z in [-50, 50] mm,
// thickness along y in [-2, 2] mm with +y the outer (anterior) side, so it can be placed in
// front of the liver by a translation only.
SetFactory("Built-in");
DefineConstant[ nx = {9, Name "nx"}, nz = {8, Name "nz"} ];  // nodes along x and z
w = 100; h = 100; t = 4;
Point(1) = {-w / 2, -t / 2, -h / 2};
Point(2) = { w / 2, -t / 2, -h / 2};
Point(3) = { w / 2, -t / 2,  h / 2};
Point(4) = {-w / 2, -t / 2,  h / 2};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1, 3} = nx;
Transfinite Curve{2, 4} = nz;
Transfinite Surface{1};
Extrude {0, t, 0} { Surface{1}; Layers{1}; }

Mesh.RandomSeed = 1;
General.NumThreads = 1;
Mesh.ScalingFactor = 0.001;  // mm -> m
Mesh.Binary = 0;
