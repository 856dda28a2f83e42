// The ray queries of a kernel that traces (query.wgsl: `closest` and its stepped form,
// `occluded_short`, `occluded_step`), over the walk of the one accelerator the variant
// holds: the candidate-table walk (`CUBE`: walk.wgsl over tables.wgsl, which brings the
// BVH walk or the ray queries for rays leaving surfaces), the BVH walk (`BVH`), brute force
// (`BRUTE`) or the platform's ray queries (`RAYQUERY`), over the scene's layout and
// intersection code. The kernels include this file, not the accelerators', so that which
// walk a kernel gets is decided in one place.
#include "shared/layout.wgsl"
#include "shared/wavefront.wgsl"
#include "shared/counters.wgsl"
#include "shared/geometry.wgsl"
#include "shared/intersect.wgsl"
#include "shared/closest.wgsl"
#if CUTOUTS
#if TEXTURES
#include "shared/texture.wgsl"
#endif
#endif
#if CUBE
#include "shared/tables.wgsl"
#include "shared/walk.wgsl"
#endif
#if BVH
#include "shared/bvh.wgsl"
#endif
#if BRUTE
#include "shared/brute.wgsl"
#endif
#if RAYQUERY
#include "shared/rayquery.wgsl"
#endif
#include "shared/query.wgsl"
