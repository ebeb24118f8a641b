// Shared helpers for the grid kernels: workgroup size as specialization constant 0 and the
// linear invocation index of a 2-D dispatch (see vk::groupsFor).
#ifndef BLOBVK_COMMON_GLSL
#define BLOBVK_COMMON_GLSL

layout(local_size_x_id = 0) in;

uint linearInvocation() {
  return gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x;
}

#endif
