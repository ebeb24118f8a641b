// Work groups of the per-point and per-cell grid kernels: 8 x GRID_ROWS x 1 invocations, one per
// (x, y) of a z layer, the layer in z (vk::gridGroups on the host). Eight consecutive x points
// fill one 256-bit llvmpipe vector, and the 3-D index needs no integer division — llvmpipe
// divides lane by lane, which cost more than the rest of these kernels (and than evaluating a
// pruned field tile).
#ifndef BLOBVK_GRID_DISPATCH_GLSL
#define BLOBVK_GRID_DISPATCH_GLSL

layout(local_size_x = 8, local_size_y_id = 0) in;

#endif
