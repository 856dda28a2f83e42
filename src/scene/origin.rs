//! What a ray starts from, the key of a direction-cube table.

/// A ray's origin entity: what its table is keyed by (`coherence`), and what the CPU
/// reference's accelerators are told a ray leaves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OriginKey {
    /// Primary rays from the camera.
    Eye,
    /// Shadow rays traced from light `i` (index into `Scene::lights`) toward a point.
    Light(usize),
    /// Secondary rays leaving primitive `id` (reflection, refraction, and shadow rays towards
    /// lights without a table): no table; the GPU walks the BVH for them, the tables'
    /// walker the fallback origin.
    Surface(u32),
}
